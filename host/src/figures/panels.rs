//! Panels: several line figures in one, stacked vertically or side by side
//! (the time series and the profiles of a run).

use super::{Figure, LinesFigure, Px};
use plotters::coord::Shift;
use plotters::prelude::*;

/// Figures in panels of 900 × 260 stacked vertically, or of 400 × 560 side
/// by side.
pub struct Panels {
    /// The panels, top to bottom or left to right.
    pub panels: Vec<LinesFigure>,
    /// Side by side rather than stacked.
    pub side_by_side: bool,
}

impl Figure for Panels {
    fn size(&self) -> (u32, u32) {
        let n = self.panels.len().max(1) as u32;
        if self.side_by_side {
            (400 * n, 560)
        } else {
            (900, 260 * n)
        }
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        px: Px,
    ) -> Result<(), String> {
        let n = self.panels.len().max(1);
        let areas = if self.side_by_side {
            root.split_evenly((1, n))
        } else {
            root.split_evenly((n, 1))
        };
        for (panel, area) in self.panels.iter().zip(&areas) {
            panel.draw(area, px)?;
        }
        Ok(())
    }
}
