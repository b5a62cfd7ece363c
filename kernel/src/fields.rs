//! [`GrainField`]: one grain's state fields by name, the vocabulary of
//! reading a field in the working precision and moving it by a number of
//! units in the last place (ULPs) — how a test or a user shows where two
//! runs part (docs/determinism.md, "Locating a divergence"). The reading
//! and the moving ([`crate::Sim::field`], [`crate::Sim::nudge`]) are an
//! `impl Sim` in `sim/fields.rs`; the names stay here, below the
//! simulation, because they need none (the host parses them).

use crate::digest::FieldGroup;

/// A per-grain state field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GrainField {
    /// Streamwise position x.
    X,
    /// Height y.
    Y,
    /// Streamwise velocity u_p.
    U,
    /// Vertical velocity v_p.
    V,
    /// Spin ω.
    Spin,
    /// The held streamwise turbulence draw (docs/model.md (15)).
    DrawU,
    /// The held vertical turbulence draw.
    DrawV,
}

impl GrainField {
    /// Every field, in the order a locator reports them.
    pub const ALL: [GrainField; 7] = [
        GrainField::X,
        GrainField::Y,
        GrainField::U,
        GrainField::V,
        GrainField::Spin,
        GrainField::DrawU,
        GrainField::DrawV,
    ];

    /// The field's name: `x`, `y`, `u`, `v`, `spin`, `draw_u`, `draw_v`.
    ///
    /// ```
    /// use mbs_kernel::GrainField;
    ///
    /// for f in GrainField::ALL {
    ///     assert_eq!(GrainField::from_name(f.name()), Some(f));
    /// }
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            GrainField::X => "x",
            GrainField::Y => "y",
            GrainField::U => "u",
            GrainField::V => "v",
            GrainField::Spin => "spin",
            GrainField::DrawU => "draw_u",
            GrainField::DrawV => "draw_v",
        }
    }

    /// The field called `name`, if any.
    pub fn from_name(name: &str) -> Option<GrainField> {
        GrainField::ALL.into_iter().find(|f| f.name() == name)
    }

    /// The [`FieldGroup`] whose digest covers this field.
    pub fn group(self) -> FieldGroup {
        match self {
            GrainField::X | GrainField::Y => FieldGroup::Positions,
            GrainField::U | GrainField::V => FieldGroup::Velocities,
            GrainField::Spin => FieldGroup::Spins,
            GrainField::DrawU | GrainField::DrawV => FieldGroup::Flow,
        }
    }
}
