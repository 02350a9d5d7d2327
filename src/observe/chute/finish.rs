//! The chute observer's last stage: from streaming state to table rows. Pure: `finish` can be
//! called at any time and sampling may go on.
//!
//! Rows whose NOT NULL columns would be undefined are left out: field points with ρ = 0 (no
//! particle within the kernel's reach) and blocks no particle visited.

use super::observer::ChuteObserver;
use super::results::{
    ChuteBlockRow, ChuteCorrelationRow, ChuteFieldRow, ChuteMsdRow, ChuteResults, ChuteSummaryRow,
    ChuteVzPdfRow,
};
use crate::observe::chute_stats::{correlation_length, d_perp};
use crate::observe::coarse_grain::ZGrid;

/// The standardised PDFs span ±5 standard deviations.
pub const PDF_HALF_RANGE_STD: f64 = 5.0;

impl ChuteObserver {
    /// Every result row so far.
    pub fn finish(&self) -> ChuteResults {
        let g = &self.geometry;
        let st = &self.settings;
        let len = g.total_length_m;
        let z0 = g.z_base_m;
        let grid = self.profiles_grid();
        let mean = self.profiles.mean();
        let nan = || vec![f64::NAN; grid.n];
        let (rho, vx, shear, sxz, szz) = match &mean {
            Some(p) => (
                p.density(),
                p.velocity_x(),
                p.shear_rate(),
                p.stress(0, 2),
                p.stress(2, 2),
            ),
            None => (nan(), nan(), nan(), nan(), nan()),
        };
        let fields: Vec<ChuteFieldRow> = (0..grid.n)
            .filter(|&k| rho[k] > 0.0 && vx[k].is_finite() && shear[k].is_finite())
            .map(|k| ChuteFieldRow {
                z_m: grid.z(k) - z0,
                density_kg_per_m3: rho[k],
                velocity_x_m_per_s: vx[k],
                shear_rate_per_s: shear[k],
                stress_xz_pa: sxz[k],
                stress_zz_pa: szz[k],
            })
            .collect();

        // Lags are counted in samples; convert with the measured mean interval, which differs
        // from the nominal one by the rounding of the engine's chunk to whole steps.
        let interval = if self.samples >= 2 {
            (self.last_time_s - self.first_time_s.unwrap_or(0.0)) / (self.samples - 1) as f64
        } else {
            st.sample_interval_s
        };
        let lag_scale = interval / st.sample_interval_s;
        let pi = std::f64::consts::PI;
        let d = g.diameter_m;
        let particle_volume = pi * d * d / 4.0 * g.cylinder_length_m + pi * d * d * d / 6.0;
        let particle_density = self.mass_sum / self.mass_count as f64 / particle_volume;

        let (mut blocks, mut msd, mut vz_pdf, mut correlation) = (vec![], vec![], vec![], vec![]);
        for (k, diffusion) in self.msd.results(lag_scale).iter().enumerate() {
            let (lo, hi) = (z0 + k as f64 * len, z0 + (k + 1) as f64 * len);
            let visits = self.block_particle_samples[k];
            let (Some(shear_k), Some(vx_k), Some(rho_k)) = (
                grid.mean_over(&shear, lo, hi),
                grid.mean_over(&vx, lo, hi),
                grid.mean_over(&rho, lo, hi),
            ) else {
                continue;
            };
            if visits == 0 {
                continue;
            }
            let block = k as u32;
            let curve = &diffusion.curve;
            for ((&lag_s, &msd_m2), &pairs) in
                curve.lags_s.iter().zip(&curve.msd_m2).zip(&curve.pairs)
            {
                msd.push(ChuteMsdRow {
                    block,
                    lag_s,
                    msd_m2,
                    pairs,
                });
            }
            let fit = diffusion.fit;

            let m = &self.vz_moments[k];
            if let Some(std) = m.std() {
                for (x, density) in
                    self.vz_pdf[k].standardised(m.mean, std, st.pdf_bin_std, PDF_HALF_RANGE_STD)
                {
                    vz_pdf.push(ChuteVzPdfRow { block, x, density });
                }
            }
            let corr = self.correlation.curve(k);
            if let Some(c) = &corr {
                for ((&r_m, &c_m2_per_s2), &pairs) in c.r_m.iter().zip(&c.c).zip(&c.pairs) {
                    correlation.push(ChuteCorrelationRow {
                        block,
                        r_m,
                        c_m2_per_s2,
                        pairs,
                    });
                }
            }
            blocks.push(ChuteBlockRow {
                block,
                z_m: (k as f64 + 0.5) * len,
                diffusion_m2_per_s: fit.map(|f| f.d),
                diffusion_stderr_m2_per_s: diffusion.stderr.filter(|s| s.is_finite()),
                msd_fit_r: fit.map(|f| f.r).filter(|r| r.is_finite()),
                shear_rate_per_s: shear_k,
                velocity_x_m_per_s: vx_k,
                solid_fraction: rho_k / particle_density,
                mean_particles: visits as f64 / self.samples as f64,
                vz_std_m_per_s: m.std(),
                vz_skewness: m.skewness(),
                correlation_length_m: corr.and_then(|c| correlation_length(&c.r_m, &c.c)),
                nematic_order: None,
                mean_abs_cos_flow: None,
                diffusion_y_m2_per_s: None,
                diffusion_y_stderr_m2_per_s: None,
            });
        }
        self.fill_orientation_and_dy(&mut blocks, lag_scale);

        let mean_cos = self.cos_theta_sum / self.cos_theta_count as f64;
        let summary = ChuteSummaryRow {
            aspect_ratio: len / d,
            inclination_deg: g.inclination_deg,
            total_length_m: len,
            diameter_m: d,
            particles: self.particles as u64,
            bed_height_m: bed_height(&grid, &rho).map_or(0.0, |z| z - z0),
            steady_time_s: None,
            steady_stress_ratio: None,
            measure_start_s: self.first_time_s.unwrap_or(f64::NAN),
            measure_end_s: if self.samples > 0 {
                self.last_time_s
            } else {
                f64::NAN
            },
            samples: self.samples,
            msd_fit_min_lag_s: st.fit_min_lag_s,
            msd_fit_max_lag_s: st.fit_max_lag(),
            mean_cos_theta: mean_cos,
            d_perp_m: d_perp(d, g.cylinder_length_m, mean_cos),
            cg_width_m: self.kernel.width_m,
            steady: false,
        };
        ChuteResults {
            summary,
            blocks,
            msd,
            fields,
            vz_pdf,
            correlation,
        }
    }
}

impl ChuteObserver {
    /// Sets each block row's S2, ⟨|cos θ|⟩ (rods) and D_y with its error, where measured.
    fn fill_orientation_and_dy(&self, blocks: &mut [ChuteBlockRow], lag_scale: f64) {
        let lateral = self.lateral.as_ref().map(|l| l.results(lag_scale));
        for row in blocks {
            let k = row.block as usize;
            if let Some(o) = &self.orientation {
                row.nematic_order = o.order(k).filter(|s| s.is_finite());
                row.mean_abs_cos_flow = o.mean_abs_cos(k).filter(|c| c.is_finite());
            }
            if let Some(dy) = lateral.as_ref().map(|l| &l[k]) {
                row.diffusion_y_m2_per_s = dy.fit.map(|f| f.d).filter(|d| d.is_finite());
                row.diffusion_y_stderr_m2_per_s = dy.stderr.filter(|s| s.is_finite());
            }
        }
    }
}

/// The z (grid coordinates) where ρ first falls below half its bulk value going up from the
/// bulk, interpolated linearly between grid points. The bulk value is the mean ρ between the
/// heights below which 25 % and 75 % of the mass lie: that excludes the layering at the base and
/// the dilute surface without knowing the bed height first. The grid top if ρ never falls that
/// low; None without mass.
fn bed_height(grid: &ZGrid, rho: &[f64]) -> Option<f64> {
    let mut cumulative = vec![0.0; grid.n];
    for k in 1..grid.n {
        let seg = 0.5 * (rho[k - 1] + rho[k]) * grid.dz_m;
        cumulative[k] = cumulative[k - 1] + if seg.is_finite() { seg } else { 0.0 };
    }
    let total = *cumulative.last()?;
    if !(total > 0.0) {
        return None;
    }
    let quantile = |q: f64| {
        let k = cumulative.iter().position(|&c| c >= q * total)?;
        if k == 0 {
            return Some(grid.z(0));
        }
        let (c0, c1) = (cumulative[k - 1], cumulative[k]);
        Some(grid.z(k - 1) + grid.dz_m * (q * total - c0) / (c1 - c0))
    };
    let (z25, z75) = (quantile(0.25)?, quantile(0.75)?);
    let half = 0.5 * grid.mean_over(rho, z25, z75)?;
    let start = (((z75 - grid.z0_m) / grid.dz_m).ceil().max(1.0) as usize).min(grid.n);
    for k in start..grid.n {
        if rho[k] < half {
            let (r0, r1) = (rho[k - 1], rho[k]);
            return Some(grid.z(k - 1) + grid.dz_m * (r0 - half) / (r0 - r1));
        }
    }
    Some(grid.z(grid.n - 1))
}
