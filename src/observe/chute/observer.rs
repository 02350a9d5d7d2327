//! The chute observer's state and its per-snapshot stage: coarse-grained profiles, MSD per
//! block, v_z moments and PDFs per block, C(r) every few snapshots, the mean orientation, and
//! per block the rods' nematic order S2 and ⟨|cos θ|⟩ and the MSD of y (D_y).
//!
//! Blocks are layers k = floor((z − z_base)/L): for the MSD by the mean height of a particle's
//! whole trajectory (or of the lag window, `msd_blocks`), for v_z statistics, C(r) and particle
//! counts by its height in the snapshot.
//! Everything here is serde-serialisable, so the observer is checkpointed mid-stream and resumes
//! bit for bit. The per-block orientation and D_y came later (schema 13): an observer
//! checkpointed before has neither; it resumes without them (their columns stay NULL: they
//! would cover only part of the measurement) and everything else as it would have.

use serde::{Deserialize, Serialize};

use super::lateral::LateralMsd;
use super::settings::{ChuteGeometry, ChuteObserverSettings, SettingProblem};
use crate::engine::contact::ContactRecord;
use crate::observe::chute_stats::{
    cos_theta, BlockOrientation, Moments, StandardisedPdf, VzCorrelation,
};
use crate::observe::coarse_grain::{bulk_stress_ratio, Kernel, ZGrid, ZProfile, ZProfileAverage};
use crate::observe::msd::{BlockMsd, MsdLayout};

/// The flow direction: gravity is g (sin α, 0, −cos α).
pub(super) const FLOW_DIR: [f64; 3] = [1.0, 0.0, 0.0];

/// One downloaded state, flowing particles only.
pub struct ChuteSnapshot<'a> {
    /// Simulated time (s).
    pub time_s: f64,
    /// Stable ids, any order (the MSD matches particles by id).
    pub id: &'a [u32],
    /// Centres (m), wrapped into the periodic box: x in [0, box_x), y in [0, box_y).
    pub pos: &'a [[f64; 3]],
    /// Velocities (m/s).
    pub vel: &'a [[f64; 3]],
    /// Unit body axes.
    pub axis: &'a [[f64; 3]],
    /// Masses (kg).
    pub mass: &'a [f64],
    /// Contacts of flowing particles (with each other once, with the base, with walls).
    pub contacts: &'a [ContactRecord],
}

/// Streaming state of the chute observer (checkpointed with the job).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChuteObserver {
    pub settings: ChuteObserverSettings,
    pub geometry: ChuteGeometry,
    pub(super) kernel: Kernel,
    pub(super) blocks: usize,
    pub(super) profiles: ZProfileAverage,
    pub(super) msd: BlockMsd,
    pub(super) vz_moments: Vec<Moments>,
    pub(super) vz_pdf: Vec<StandardisedPdf>,
    pub(super) correlation: VzCorrelation,
    /// Particle-snapshots per block.
    pub(super) block_particle_samples: Vec<u64>,
    /// Σ cos θ and its count, over all particles and snapshots.
    pub(super) cos_theta_sum: f64,
    pub(super) cos_theta_count: u64,
    /// Σ m and its count, for the particle density (the chute is monodisperse).
    pub(super) mass_sum: f64,
    pub(super) mass_count: u64,
    pub(super) samples: u64,
    pub(super) first_time_s: Option<f64>,
    /// Time of the last snapshot (s); 0 before the first (not NaN: JSON has no NaN).
    pub(super) last_time_s: f64,
    /// Flowing particles in the last snapshot.
    pub(super) particles: usize,
    /// S2 and ⟨|cos θ|⟩ per block: rods only (None for spheres, which have no axis), and None
    /// in an observer checkpointed before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) orientation: Option<BlockOrientation>,
    /// MSD of y per block (D_y); None in an observer checkpointed before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) lateral: Option<LateralMsd>,
}

impl ChuteObserver {
    /// An observer with nothing sampled yet.
    ///
    /// # Errors
    /// Every out-of-range setting and geometry value.
    pub fn new(
        settings: ChuteObserverSettings,
        geometry: ChuteGeometry,
    ) -> Result<Self, Vec<SettingProblem>> {
        let mut problems = settings.problems();
        problems.extend(geometry.problems());
        if !problems.is_empty() {
            return Err(problems);
        }
        let len = geometry.total_length_m;
        let (z_base, z_top) = (geometry.z_base_m, geometry.z_top_m);
        let blocks = ((z_top - z_base) / len - 1e-9).ceil() as usize;
        let kernel = Kernel::new(
            settings.cg_width_over_length * len,
            settings.cg_cutoff_widths,
        );
        let grid = ZGrid::spanning(z_base, z_top, settings.field_dz_over_length * len);
        let layout = MsdLayout {
            interval_s: settings.sample_interval_s,
            max_lag_s: settings.max_lag_s,
            block_height_m: len,
            z_base_m: z_base,
            blocks,
            assignment: settings.msd_blocks,
            fit_min_lag_s: settings.fit_min_lag_s,
            fit_max_lag_s: settings.fit_max_lag(),
            error_windows: settings.msd_error_windows as usize,
        };
        Ok(Self {
            kernel,
            blocks,
            profiles: ZProfileAverage::new(grid),
            lateral: Some(LateralMsd::new(layout.clone(), geometry.box_y_m)),
            orientation: geometry.has_axis().then(|| BlockOrientation::new(blocks)),
            msd: BlockMsd::new(layout),
            vz_moments: vec![Moments::default(); blocks],
            vz_pdf: vec![StandardisedPdf::default(); blocks],
            correlation: VzCorrelation::new(
                settings.correlation_bin_over_length * len,
                settings.correlation_max_r_over_length * len,
                geometry.box_x_m,
                geometry.box_y_m,
                len,
                z_base,
                blocks,
            ),
            block_particle_samples: vec![0; blocks],
            cos_theta_sum: 0.0,
            cos_theta_count: 0,
            mass_sum: 0.0,
            mass_count: 0,
            samples: 0,
            first_time_s: None,
            last_time_s: 0.0,
            particles: 0,
            settings,
            geometry,
        })
    }

    /// Snapshots sampled so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// The coarse-graining kernel (width w = `cg_width_over_length` · L).
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Adds one snapshot. The runner calls this every `sample_interval_s`.
    ///
    /// # Panics
    /// If the snapshot's slices differ in length, or its time is not `sample_interval_s` (±1 %)
    /// after the previous one: the MSD's lags count samples.
    pub fn sample(&mut self, snap: &ChuteSnapshot) {
        let n = snap.id.len();
        assert!(
            [
                snap.pos.len(),
                snap.vel.len(),
                snap.axis.len(),
                snap.mass.len()
            ]
            .iter()
            .all(|&l| l == n),
            "chute snapshot: slices of different lengths"
        );
        if self.samples > 0 {
            let dt = snap.time_s - self.last_time_s;
            let want = self.settings.sample_interval_s;
            assert!(
                (dt - want).abs() <= 0.01 * want,
                "chute snapshot at t = {} s is {dt} s after the previous one, expected {want} s",
                snap.time_s
            );
        }
        let profile = self.profile_of(snap);
        self.profiles.add(&profile);

        let z: Vec<f64> = snap.pos.iter().map(|p| p[2]).collect();
        self.msd.add_sample(snap.id, &z);
        if let Some(lateral) = &mut self.lateral {
            lateral.add_sample(snap.id, &z, snap.pos);
        }
        if self.orientation.is_some() {
            let blocks: Vec<Option<usize>> = z.iter().map(|&z| self.block_at(z)).collect();
            if let Some(o) = &mut self.orientation {
                o.add_snapshot(&blocks, snap.axis, FLOW_DIR);
            }
        }

        let len = self.geometry.total_length_m;
        for (p, v) in snap.pos.iter().zip(snap.vel) {
            let k = ((p[2] - self.geometry.z_base_m) / len).floor();
            if k >= 0.0 && k < self.blocks as f64 {
                let k = k as usize;
                self.vz_moments[k].add(v[2]);
                self.vz_pdf[k].add(v[2]);
                self.block_particle_samples[k] += 1;
            }
        }
        if self
            .samples
            .is_multiple_of(u64::from(self.settings.correlation_every))
        {
            let vz: Vec<f64> = snap.vel.iter().map(|v| v[2]).collect();
            self.correlation.add_snapshot(snap.pos, &vz);
        }
        self.cos_theta_sum += snap
            .axis
            .iter()
            .map(|&u| cos_theta(u, FLOW_DIR))
            .sum::<f64>();
        self.cos_theta_count += n as u64;
        self.mass_sum += snap.mass.iter().sum::<f64>();
        self.mass_count += n as u64;

        self.first_time_s.get_or_insert(snap.time_s);
        self.last_time_s = snap.time_s;
        self.particles = n;
        self.samples += 1;
    }

    /// Bulk μ = −σ_xz/σ_zz of one snapshot over heights [z_lo_m, z_hi_m] above the base, without
    /// touching the observer's state: the stress ratio of the steady-state test (see
    /// `coarse_grain::bulk_stress_ratio` for the sign).
    pub fn stress_ratio(&self, snap: &ChuteSnapshot, z_lo_m: f64, z_hi_m: f64) -> Option<f64> {
        let z0 = self.geometry.z_base_m;
        bulk_stress_ratio(&self.profile_of(snap), z0 + z_lo_m, z0 + z_hi_m)
    }

    /// The coarse-grained profile of one snapshot.
    fn profile_of(&self, snap: &ChuteSnapshot) -> ZProfile {
        let g = &self.geometry;
        let area = g.box_x_m * g.box_y_m;
        let mut profile = ZProfile::new(self.profiles_grid());
        profile.deposit_particles(&self.kernel, area, snap.pos, snap.vel, snap.mass);
        profile.deposit_contacts(&self.kernel, area, snap.contacts);
        profile
    }

    /// The block of height z in a snapshot (as v_z statistics assign it); None outside all.
    fn block_at(&self, z: f64) -> Option<usize> {
        let k = ((z - self.geometry.z_base_m) / self.geometry.total_length_m).floor();
        (k >= 0.0 && k < self.blocks as f64).then_some(k as usize)
    }

    pub(super) fn profiles_grid(&self) -> ZGrid {
        let g = &self.geometry;
        ZGrid::spanning(
            g.z_base_m,
            g.z_top_m,
            self.settings.field_dz_over_length * g.total_length_m,
        )
    }
}
