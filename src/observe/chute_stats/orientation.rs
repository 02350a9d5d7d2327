//! The particle size seen across the flow, d_⊥ (chute paper §3, after Hidalgo et al. 2018):
//! the diameter of the circle with the mean area of a spherocylinder's orthographic projection
//! on the plane normal to the flow lines.
//!
//! Our reading of the paper: a spherocylinder (cylinder length l, diameter d) projects onto a
//! plane as a rectangle d × l cos θ capped by two half-discs, area d l cos θ + π d²/4, where
//! l cos θ is the projected length of its axis u. With the flow along x̂ the plane is y–z and the
//! projection of u is u − (u·x̂)x̂, of length √(1 − (u·x̂)²); so cos θ = √(1 − (u·x̂)²), θ being
//! the angle between the axis and that plane (θ = 0: axis across the flow, full length seen;
//! θ = 90°: axis along the flow, only the disc d seen). The paper's wording "projection with
//! respect to the vertical direction" is ambiguous; this reading is the one that makes d_⊥ a
//! size perpendicular to the flow lines, as its text requires. For isotropic axes ⟨cos θ⟩ = π/4.

/// d_⊥ = √(4/π (d l ⟨cos θ⟩ + π d²/4)) (m), from the diameter d (m), the cylinder length
/// l = L − d (m) and ⟨cos θ⟩.
pub fn d_perp(diameter: f64, cylinder_length: f64, mean_cos_theta: f64) -> f64 {
    let pi = std::f64::consts::PI;
    (4.0 / pi * (diameter * cylinder_length * mean_cos_theta + pi * diameter * diameter / 4.0))
        .sqrt()
}

/// cos θ = √(1 − (u·f)²) for a unit axis u and the flow direction f (normalised here): the
/// length of u's projection on the plane normal to f.
pub fn cos_theta(axis: [f64; 3], flow_dir: [f64; 3]) -> f64 {
    let norm = (flow_dir[0].powi(2) + flow_dir[1].powi(2) + flow_dir[2].powi(2)).sqrt();
    let along = (axis[0] * flow_dir[0] + axis[1] * flow_dir[1] + axis[2] * flow_dir[2]) / norm;
    (1.0 - along * along).max(0.0).sqrt()
}

/// ⟨cos θ⟩ over `axes` (unit vectors); NaN for none.
pub fn mean_cos_theta(axes: &[[f64; 3]], flow_dir: [f64; 3]) -> f64 {
    axes.iter().map(|&u| cos_theta(u, flow_dir)).sum::<f64>() / axes.len() as f64
}
