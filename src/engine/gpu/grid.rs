//! The host's choices for the device-side neighbour search, made at each upload: the cell grid
//! (origin, widths, counts), the neighbour-list capacity per particle and the scan's run length.
//! The grid only has to be a correct binning: a particle outside it is clamped into the edge cell
//! (still found by its neighbours, just slower), so it is sized once from the uploaded positions.

use crate::engine::config::EngineConfig;
use crate::engine::state::State;

/// A uniform cell grid and list capacity, in the precision the kernels use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridSpec {
    pub lo: [f32; 3],
    pub width: [f32; 3],
    pub dims: [u32; 3],
    pub ncell: u32,
    /// Neighbour-list capacity per particle.
    pub stride: u32,
    /// Cells per block of the cell-start scan, and the number of blocks.
    pub scan_chunk: u32,
    pub n_chunks: u32,
}

/// Chooses the grid for `state`.
pub fn plan_grid(state: &State<f64>, config: &EngineConfig) -> GridSpec {
    let n = state.len();
    // The reach of a particle from its centre: its radius, plus l/2 for a spherocylinder (as
    // the CPU's grid.rs). Cells are sized from the longest particle.
    let reach = |k: usize| state.radius[k] + state.half_length.get(k).copied().unwrap_or(0.0);
    let r_max = (0..n).map(reach).fold(0.0f64, f64::max);
    let skin = config.skin_m;
    let stride = if state.oriented {
        // A rod packs like a sphere of its own volume, r³ + 3/2 r² l/2 (π r² l + 4/3 π r³).
        let r_eq = (0..n)
            .map(|k| {
                let (r, h) = (state.radius[k], state.half_length[k]);
                (r * r * r + 1.5 * r * r * h).cbrt()
            })
            .fold(f64::MAX, f64::min);
        let r_eq = if n == 0 {
            r_max
        } else {
            r_eq.max(1e-3 * r_max)
        };
        rod_list_capacity(r_eq, r_max, skin)
    } else {
        let r_min = state.radius.iter().fold(f64::MAX, |a, &b| a.min(b));
        let r_min = if n == 0 {
            r_max
        } else {
            r_min.max(1e-3 * r_max)
        };
        list_capacity(r_min, r_max, skin)
    };
    // The cell is a hair wider than the largest cutoff so that f32 rounding of (x − lo)/w never
    // puts two particles within the cutoff two cells apart.
    let mut cell = ((2.0 * r_max + skin) * (1.0 + 1e-5)).max(f64::MIN_POSITIVE);
    let mut lo = [f64::MAX; 3];
    let mut hi = [f64::MIN; 3];
    for p in &state.pos {
        for (k, x) in [p.x, p.y, p.z].into_iter().enumerate() {
            lo[k] = lo[k].min(x);
            hi[k] = hi[k].max(x);
        }
    }
    if n == 0 {
        lo = [0.0; 3];
        hi = [0.0; 3];
    }
    if let Some(z) = config.sink_z {
        // Particles falling to the sink stay in real cells.
        lo[2] = lo[2].min(z);
    }
    let periodic = [config.periodic_x, config.periodic_y, None];
    let bounds = |cell: f64| -> ([f64; 3], [f64; 3]) {
        let mut a = lo;
        let mut b = hi;
        for k in 0..3 {
            match periodic[k] {
                Some([p, q]) => {
                    a[k] = p;
                    b[k] = q;
                }
                None => {
                    a[k] -= 2.0 * cell;
                    b[k] += 2.0 * cell;
                }
            }
        }
        (a, b)
    };
    let dims_for = |cell: f64| -> [u32; 3] {
        let (a, b) = bounds(cell);
        std::array::from_fn(|k| (((b[k] - a[k]).max(cell) / cell).floor() as u32).max(1))
    };
    // A stray particle far away must not blow up the cell count (as grid.rs: cells ≤ 8N + 4096).
    while dims_for(cell).iter().map(|&d| d as f64).product::<f64>() > (8 * n + 4096) as f64 {
        cell *= 1.5;
    }
    let dims = dims_for(cell);
    let (a, b) = bounds(cell);
    let width: [f32; 3] =
        std::array::from_fn(|k| ((b[k] - a[k]).max(cell) / dims[k] as f64) as f32);
    let ncell = dims[0] * dims[1] * dims[2];
    let scan_chunk = super::layout::WORKGROUP_SIZE * super::layout::SCAN_ITEMS;
    GridSpec {
        lo: std::array::from_fn(|k| a[k] as f32),
        width,
        dims,
        ncell,
        stride,
        scan_chunk,
        n_chunks: ncell.div_ceil(scan_chunk),
    }
}

/// Neighbours a list row holds: a packing bound on the spheres of radius ≥ r_min whose centres
/// lie within r_max + r_min + skin (density 0.75 of the ball of radius cutoff + r_min, radii
/// shrunk by 10 % for overlaps), rounded up to a multiple of 4, between 32 and 256. A run that
/// still overflows it fails with a clear error rather than dropping a contact.
pub fn list_capacity(r_min: f64, r_max: f64, skin: f64) -> u32 {
    packing_bound(r_max + r_min + skin + r_min, r_min)
}

/// Neighbours a list row holds in an oriented run: the centres within the cutoff 2 r_max + skin
/// (r_max the longest reach r + l/2), each particle inside the ball of radius cutoff + r_max and
/// at least as large as a sphere of radius `r_eq` (the smallest particle's volume), packed as in
/// `list_capacity`.
pub fn rod_list_capacity(r_eq: f64, r_max: f64, skin: f64) -> u32 {
    packing_bound(3.0 * r_max + skin, r_eq)
}

/// 0.75 of the ball of radius `ball` filled with spheres of radius 0.9 `r_min`, rounded up to a
/// multiple of 4, between 32 and 256.
fn packing_bound(ball: f64, r_min: f64) -> u32 {
    let bound = 0.75 * (ball / (0.9 * r_min)).powi(3);
    let k = if bound.is_finite() {
        bound.ceil() as u32
    } else {
        256
    };
    k.div_ceil(4)
        .saturating_mul(4)
        .clamp(32, super::layout::MAX_LIST)
}
