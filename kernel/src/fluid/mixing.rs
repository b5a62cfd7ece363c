//! The mixing length of the coupled flow (docs/model.md (C3)): Li & Sawamoto
//! (1995), as Maurin et al. (2015) use it, times the free-surface factor that
//! makes the eddy viscosity of clear water parabolic.

use crate::real::Real;

/// Fills `out[j]` with the mixing length l_m at face j (the bottom of cell
/// j, m) for the solid fractions `phi` of the cells, docs/model.md (C3):
/// λ(y) = κ ∫₀^y (φ_max − φ̃)/φ_max dy' and l_m = λ √(1 − λ/λ_s), λ_s the
/// value at the free surface. φ̃ is φ_max in and below the highest cell
/// whose φ reaches φ_max (the packed bed, where turbulence is damped out),
/// min(φ, φ_max) above it. `out` and `phi` have the column's cells.
pub(crate) fn mixing_lengths<R: Real>(phi: &[R], phi_max: R, kappa: R, dy: R, out: &mut [R]) {
    let packed = phi.iter().rposition(|&p| p >= phi_max);
    let step = kappa * dy / phi_max;
    let mut lambda = R::ZERO;
    for (j, (l, &p)) in out.iter_mut().zip(phi).enumerate() {
        *l = lambda;
        let open = match packed {
            Some(top) if j <= top => R::ZERO,
            _ => phi_max - R::min(p, phi_max),
        };
        lambda += step * open;
    }
    let surface = lambda;
    if surface > R::ZERO {
        for l in out.iter_mut() {
            *l = *l * R::sqrt(R::max(R::ONE - *l / surface, R::ZERO));
        }
    }
}
