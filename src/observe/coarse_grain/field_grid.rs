//! Uniform grids for 2-D and 3-D coarse-grained fields: axisymmetric (r, z; fields averaged over
//! θ, vectors and tensors in the cylindrical basis r, θ, z) and Cartesian (x, y, z). Point
//! (i, j, k) has index (k·ny + j)·nx + i, axis 0 fastest (the store's and VTK's order).
//!
//! Only geometry and quadrature weights; the fields live in `GridFields`.

use serde::{Deserialize, Serialize};

/// Which coordinates a grid spans.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum GridKind {
    /// Axis 0 = r, axis 1 = z, axis 2 unused (n = 1).
    Rz,
    /// Axes x, y, z.
    Xyz,
}

impl GridKind {
    /// The store's name (`field_sets.grid_kind`).
    pub fn name(self) -> &'static str {
        match self {
            GridKind::Rz => "rz",
            GridKind::Xyz => "xyz",
        }
    }
}

/// Points origin + index × spacing along each axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FieldGrid {
    pub kind: GridKind,
    pub origin_m: [f64; 3],
    pub spacing_m: [f64; 3],
    pub shape: [usize; 3],
}

impl FieldGrid {
    /// An (r, z) grid of cells of size dr × dz covering r ∈ [0, r_max] and z ∈ [z_lo, z_hi],
    /// points at cell centres in r (r = (i + ½) dr: the volume 2π r dr dz of each cell is then
    /// the midpoint rule, and no point sits on the axis) and at z_lo + j dz in z (so a z_lo that
    /// is a multiple of dz puts a row of points on z = 0).
    pub fn rz(r_max: f64, z_lo: f64, z_hi: f64, dr: f64, dz: f64) -> Self {
        let nr = ((r_max / dr) - 1e-9).ceil().max(1.0) as usize;
        let nz = ((z_hi - z_lo) / dz + 1e-9).floor().max(0.0) as usize + 1;
        Self {
            kind: GridKind::Rz,
            origin_m: [0.5 * dr, z_lo, 0.0],
            spacing_m: [dr, dz, 0.0],
            shape: [nr, nz, 1],
        }
    }

    /// A Cartesian grid with spacing h from `lo` to at most `hi` (m) on each axis.
    pub fn xyz(lo: [f64; 3], hi: [f64; 3], h: f64) -> Self {
        let n = |a: usize| ((hi[a] - lo[a]) / h + 1e-9).floor().max(0.0) as usize + 1;
        Self {
            kind: GridKind::Xyz,
            origin_m: lo,
            spacing_m: [h, h, h],
            shape: [n(0), n(1), n(2)],
        }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.shape.iter().product()
    }

    /// Whether the grid has no point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Coordinate of index `i` along `axis` (m).
    pub fn coord(&self, axis: usize, i: usize) -> f64 {
        self.origin_m[axis] + i as f64 * self.spacing_m[axis]
    }

    /// Index of point (i, j, k).
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.shape[1] + j) * self.shape[0] + i
    }

    /// Indices along `axis` of the points with coordinate in [lo, hi].
    pub fn range(&self, axis: usize, lo: f64, hi: f64) -> std::ops::Range<usize> {
        let (o, h, n) = (self.origin_m[axis], self.spacing_m[axis], self.shape[axis]);
        if h == 0.0 {
            return 0..n;
        }
        let first = ((lo - o) / h).ceil().max(0.0);
        let last = ((hi - o) / h).floor();
        if last < 0.0 || first >= n as f64 || first > last {
            return 0..0;
        }
        first as usize..(last as usize + 1).min(n)
    }

    /// Volume that point `p` stands for in ∫ f dV (m³): 2π r dr dz for (r, z) (midpoint rule
    /// in r), dx dy dz for Cartesian.
    pub fn volume(&self, p: usize) -> f64 {
        match self.kind {
            GridKind::Rz => {
                let i = p % self.shape[0];
                std::f64::consts::TAU * self.coord(0, i) * self.spacing_m[0] * self.spacing_m[1]
            }
            GridKind::Xyz => self.spacing_m.iter().product(),
        }
    }
}
