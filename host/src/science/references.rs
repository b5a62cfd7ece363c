//! Measured bed-load relations q*(τ*) of docs/model.md §10.

use serde::{Deserialize, Serialize};

/// A reference bed-load relation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Reference {
    /// Meyer-Peter & Müller (1948): 8 (τ* − 0.047)^1.5.
    MeyerPeterMuller,
    /// Wong & Parker (2006): 3.97 (τ* − 0.0495)^1.5.
    WongParker,
    /// Fernandez Luque & van Beek (1976): 5.7 (τ* − 0.037)^1.5.
    FernandezLuqueVanBeek,
    /// Ashida & Michiue (1972): 17 (τ* − 0.05)(√τ* − √0.05).
    AshidaMichiue,
    /// Nielsen (1992): 12 √τ* (τ* − 0.05).
    Nielsen,
}

impl Reference {
    /// Every relation, in the order they are plotted.
    pub const ALL: [Reference; 5] = [
        Reference::MeyerPeterMuller,
        Reference::WongParker,
        Reference::FernandezLuqueVanBeek,
        Reference::AshidaMichiue,
        Reference::Nielsen,
    ];

    /// The relation's authors and year.
    pub fn name(self) -> &'static str {
        match self {
            Reference::MeyerPeterMuller => "Meyer-Peter & Müller 1948",
            Reference::WongParker => "Wong & Parker 2006",
            Reference::FernandezLuqueVanBeek => "Fernandez Luque & van Beek 1976",
            Reference::AshidaMichiue => "Ashida & Michiue 1972",
            Reference::Nielsen => "Nielsen 1992",
        }
    }

    /// The critical Shields number τ*c used (docs/model.md §10).
    pub fn tau_star_c(self) -> f64 {
        match self {
            Reference::MeyerPeterMuller => 0.047,
            Reference::WongParker => 0.0495,
            Reference::FernandezLuqueVanBeek => 0.037,
            Reference::AshidaMichiue | Reference::Nielsen => 0.05,
        }
    }

    /// Label for plots and reports: the name and τ*c.
    pub fn label(self) -> String {
        format!("{} (τ*c {})", self.name(), self.tau_star_c())
    }

    /// q* at Shields number `tau`; 0 below the relation's threshold.
    pub fn q_star(self, tau: f64) -> f64 {
        let tc = self.tau_star_c();
        let excess = (tau - tc).max(0.0);
        match self {
            Reference::MeyerPeterMuller => 8.0 * excess.powf(1.5),
            Reference::WongParker => 3.97 * excess.powf(1.5),
            Reference::FernandezLuqueVanBeek => 5.7 * excess.powf(1.5),
            Reference::AshidaMichiue => 17.0 * excess * (tau.max(0.0).sqrt() - tc.sqrt()).max(0.0),
            Reference::Nielsen => 12.0 * tau.max(0.0).sqrt() * excess,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_at_chosen_shields_numbers() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12 * b.abs().max(1.0);
        assert!(close(
            Reference::MeyerPeterMuller.q_star(0.147),
            8.0 * 0.1f64.powf(1.5)
        ));
        assert!(close(
            Reference::WongParker.q_star(0.1495),
            3.97 * 0.001f64.sqrt()
        ));
        assert!(close(
            Reference::FernandezLuqueVanBeek.q_star(0.137),
            5.7 * 0.1f64.powf(1.5)
        ));
        assert!(close(
            Reference::AshidaMichiue.q_star(0.2),
            17.0 * 0.15 * (0.2f64.sqrt() - 0.05f64.sqrt())
        ));
        assert!(close(Reference::Nielsen.q_star(0.25), 12.0 * 0.5 * 0.2));
        for r in Reference::ALL {
            assert_eq!(r.q_star(0.03), 0.0, "{r:?} below threshold");
            assert!(r.q_star(0.5) > r.q_star(0.2), "{r:?} increases");
        }
    }
}
