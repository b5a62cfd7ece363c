//! Fractional bed-load transport of a sand or gravel mixture with hiding:
//! the surface-based relation of Wilcock & Crowe (2003), in the q* terms of
//! docs/model.md §8 (docs/model.md §10, "Mixed sizes").

/// Geometric mean diameter exp(Σ f_k ln d_k) of classes of `diameters`
/// with volume `fractions` (summing to 1): Wilcock & Crowe's D_sm when the
/// fractions are those of the bed surface.
///
/// ```
/// use mbs::science::mixture::geometric_mean;
///
/// assert!((geometric_mean(&[1.0, 4.0], &[0.5, 0.5]) - 2.0).abs() < 1e-15);
/// ```
pub fn geometric_mean(diameters: &[f64], fractions: &[f64]) -> f64 {
    diameters
        .iter()
        .zip(fractions)
        .map(|(d, f)| f * d.ln())
        .sum::<f64>()
        .exp()
}

/// Wilcock & Crowe's transport function W*(φ): 0.002 φ^7.5 below φ = 1.35,
/// 14 (1 − 0.894/√φ)^4.5 above.
pub fn wilcock_crowe_w(phi: f64) -> f64 {
    if phi < 1.35 {
        0.002 * phi.max(0.0).powf(7.5)
    } else {
        14.0 * (1.0 - 0.894 / phi.sqrt()).powf(4.5)
    }
}

/// Fractional transport q*_k / f_k of class k on its own scale
/// (q*_k = q_Bk/√((s − 1) g d_k³)) by Wilcock & Crowe (2003):
///
/// - reference Shields number of the surface mean,
///   τ*_rsm = 0.021 + 0.015 exp(−20 F_s), F_s the sand fraction (< 2 mm);
/// - hiding: τ_rk = τ_rsm (d_k/D_sm)^b, b = 0.67 / (1 + exp(1.5 − d_k/D_sm));
/// - φ = τ/τ_rk and W*_k = (s − 1) g q_Bk / (f_k u*³) = W*(φ), so that
///   q*_k / f_k = W*(φ) τ*_k^1.5.
///
/// `tau_star_k` is the Shields number on d_k (τ* d_max/d_k for a τ* on
/// d_max), `d_k` and `d_sm` in the same unit.
///
/// ```
/// use mbs::science::mixture::{wilcock_crowe, wilcock_crowe_w};
///
/// // A uniform sand (d_k = D_sm, F_s = 1) at twice its reference stress:
/// let tau_r = 0.021 + 0.015 * (-20.0f64).exp();
/// let q = wilcock_crowe(2.0 * tau_r, 0.5, 0.5, 1.0);
/// assert!((q - wilcock_crowe_w(2.0) * (2.0 * tau_r).powf(1.5)).abs() < 1e-15);
/// ```
pub fn wilcock_crowe(tau_star_k: f64, d_k: f64, d_sm: f64, sand_fraction: f64) -> f64 {
    let tau_star_rsm = 0.021 + 0.015 * (-20.0 * sand_fraction).exp();
    let ratio = d_k / d_sm;
    let b = 0.67 / (1.0 + (1.5 - ratio).exp());
    // τ on D_sm's scale over τ_rk on D_sm's scale.
    let phi = tau_star_k * ratio / (tau_star_rsm * ratio.powf(b));
    wilcock_crowe_w(phi) * tau_star_k.max(0.0).powf(1.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_two_branches_of_w_meet_at_1_35() {
        let (below, above) = (wilcock_crowe_w(1.35 - 1e-12), wilcock_crowe_w(1.35));
        // Wilcock & Crowe's fit is continuous to 1 %.
        assert!((below / above - 1.0).abs() < 0.01, "{below} {above}");
        assert_eq!(wilcock_crowe_w(1.0), 0.002);
        assert!((wilcock_crowe_w(1e12) - 14.0).abs() < 1e-3);
    }

    #[test]
    fn hiding_helps_fine_grains_and_hinders_coarse_ones() {
        // 0.7 and 0.5 mm, half and half: at the same τ*_k the finer class,
        // hidden among coarser grains, moves less than alone, and the
        // coarser, exposed, more.
        let d_sm = geometric_mean(&[0.7, 0.5], &[0.5, 0.5]);
        let alone = |d: f64, t: f64| wilcock_crowe(t, d, d, 1.0);
        let t = 0.1;
        assert!(wilcock_crowe(t, 0.5, d_sm, 1.0) < alone(0.5, t));
        assert!(wilcock_crowe(t, 0.7, d_sm, 1.0) > alone(0.7, t));
        // With hiding complete (b = 1) every class would move at the same
        // τ on D_sm: the exponent b lies between 0 and 0.67.
        let b = |r: f64| 0.67 / (1.0 + (1.5 - r).exp());
        assert!(b(1.0) > 0.0 && b(1.0) < 0.67);
    }
}
