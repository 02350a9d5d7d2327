//! Orientational order of rods: the nematic tensor Q = ⟨(3 u⊗u − I)/2⟩ over unit axes u, its
//! largest eigenvalue S2 (1 for rods all parallel, 0 for isotropic axes in the limit of many,
//! 1/4 for axes isotropic in a plane; between 0 and 1 for any set of axes), and |cos θ| = |u·f|, θ the
//! angle between an axis and the flow direction f (⟨|cos θ|⟩ = 1/2 for isotropic axes in 3D,
//! 2/π for axes isotropic in a plane holding f, 1 along f).
//!
//! Q is symmetric and traceless; it is kept as its six upper components
//! [xx, yy, zz, xy, xz, yz] so sums of it can be checkpointed and averaged.

/// A symmetric 3 × 3 tensor as [xx, yy, zz, xy, xz, yz].
pub type Sym3 = [f64; 6];

/// (3 u⊗u − I)/2 for one unit axis u.
pub fn q_of(u: [f64; 3]) -> Sym3 {
    [
        1.5 * u[0] * u[0] - 0.5,
        1.5 * u[1] * u[1] - 0.5,
        1.5 * u[2] * u[2] - 0.5,
        1.5 * u[0] * u[1],
        1.5 * u[0] * u[2],
        1.5 * u[1] * u[2],
    ]
}

/// Q = ⟨(3 u⊗u − I)/2⟩ over `axes` (unit vectors); None for none.
pub fn q_tensor(axes: &[[f64; 3]]) -> Option<Sym3> {
    if axes.is_empty() {
        return None;
    }
    let mut q = [0.0; 6];
    for &u in axes {
        for (s, v) in q.iter_mut().zip(q_of(u)) {
            *s += v;
        }
    }
    Some(q.map(|s| s / axes.len() as f64))
}

/// The largest eigenvalue of a symmetric 3 × 3 tensor, in closed form (the trigonometric
/// solution of the characteristic cubic, O. K. Smith 1961): with q = tr A/3,
/// p = √(tr (A − qI)²/6) and B = (A − qI)/p, λ_max = q + 2p cos(acos(det B/2)/3).
pub fn largest_eigenvalue(a: Sym3) -> f64 {
    let [xx, yy, zz, xy, xz, yz] = a;
    let off = xy * xy + xz * xz + yz * yz;
    let q = (xx + yy + zz) / 3.0;
    let (dx, dy, dz) = (xx - q, yy - q, zz - q);
    let p2 = dx * dx + dy * dy + dz * dz + 2.0 * off;
    if p2 <= 0.0 {
        return q;
    }
    let p = (p2 / 6.0).sqrt();
    let (bx, by, bz, bxy, bxz, byz) = (dx / p, dy / p, dz / p, xy / p, xz / p, yz / p);
    let det =
        bx * (by * bz - byz * byz) - bxy * (bxy * bz - byz * bxz) + bxz * (bxy * byz - by * bxz);
    let phi = (0.5 * det).clamp(-1.0, 1.0).acos() / 3.0;
    q + 2.0 * p * phi.cos()
}

/// S2: the largest eigenvalue of Q over `axes`; None for none.
pub fn nematic_order(axes: &[[f64; 3]]) -> Option<f64> {
    q_tensor(axes).map(largest_eigenvalue)
}

/// |cos θ| = |u·f| / |f| for a unit axis u and the flow direction f.
pub fn abs_cos_to(axis: [f64; 3], flow_dir: [f64; 3]) -> f64 {
    let norm = (flow_dir[0].powi(2) + flow_dir[1].powi(2) + flow_dir[2].powi(2)).sqrt();
    ((axis[0] * flow_dir[0] + axis[1] * flow_dir[1] + axis[2] * flow_dir[2]) / norm).abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Diagonal tensors and a rotated one with known eigenvalues, to rounding.
    #[test]
    fn largest_eigenvalue_of_known_tensors() {
        assert_eq!(largest_eigenvalue([1.0, -0.5, -0.5, 0.0, 0.0, 0.0]), 1.0);
        assert!((largest_eigenvalue([-0.5, 0.25, 0.25, 0.0, 0.0, 0.0]) - 0.25).abs() < 1e-15);
        assert_eq!(largest_eigenvalue([0.3, 0.3, 0.3, 0.0, 0.0, 0.0]), 0.3);
        // diag(2, 1, −3) rotated by 30° about z: eigenvalues unchanged.
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let a = [
            2.0 * c * c + s * s,
            2.0 * s * s + c * c,
            -3.0,
            (2.0 - 1.0) * c * s,
            0.0,
            0.0,
        ];
        assert!((largest_eigenvalue(a) - 2.0).abs() < 1e-12);
    }
}
