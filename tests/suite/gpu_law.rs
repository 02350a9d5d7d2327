//! The WGSL contact law against the Rust one, contact by contact: both laws (Hertz–Mindlin and
//! linear) and frictionless, on a table of normal, sticking, sliding and degenerate contacts and
//! on random ones. The GPU may fuse a·b + c (its SPIR-V carries no NoContraction), so the two
//! agree to f32 rounding, not to the bit: each component within 2·10⁻⁵ of the vector's size.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sweep::engine::contact::{
    contact_force, elastic_energy, ContactInput, ContactLaw, Elasticity, LawKernel, NormalModel,
};
use sweep::engine::gpu::{probe_law, ProbeContact};
use sweep::engine::V3;

use crate::common::gpu::device;

/// Relative agreement asked of each component (f32 rounding over a few dozen operations).
const TOL: f64 = 2e-5;

fn laws() -> Vec<(&'static str, LawKernel<f32>)> {
    let hertz = ContactLaw {
        normal: NormalModel::Hertz(Elasticity::YoungShear {
            youngs_modulus_pa: 3e7,
            shear_modulus_pa: 1e6,
        }),
        restitution: 0.9,
        tangential_restitution: 0.9,
        friction: 0.5,
    };
    let linear = ContactLaw {
        normal: NormalModel::Linear {
            kn_n_per_m: 2e5,
            kt_n_per_m: 2e5 * 2.0 / 7.0,
        },
        ..hertz
    };
    let frictionless = ContactLaw {
        friction: 0.0,
        ..hertz
    };
    vec![
        ("hertz", hertz.kernel()),
        ("linear", linear.kernel()),
        ("frictionless", frictionless.kernel()),
    ]
}

fn v(x: f32, y: f32, z: f32) -> V3<f32> {
    V3::new(x, y, z)
}

/// Named contacts (normal along z): a head-on approach, a sticking and a sliding tangential
/// spring, a separating (tensile) contact, a spring along the normal (nothing left in the
/// tangent plane), zero overlap, and a wall (m* the particle's mass).
fn named(law: LawKernel<f32>) -> Vec<(&'static str, ProbeContact)> {
    let base = ContactInput {
        overlap: 5e-5,
        normal: v(0.0, 0.0, 1.0),
        v_rel: v(0.0, 0.0, -0.1),
        r_eff: 1.45e-3,
        m_eff: 7e-5,
    };
    let c = |input: ContactInput<f32>, spring: V3<f32>| ProbeContact {
        law,
        input,
        spring,
        dt: 1e-6,
    };
    vec![
        ("normal", c(base, V3::zero())),
        (
            "sticking",
            c(
                ContactInput {
                    v_rel: v(1e-3, 0.0, -0.1),
                    ..base
                },
                v(1e-7, 0.0, 0.0),
            ),
        ),
        (
            "sliding",
            c(
                ContactInput {
                    v_rel: v(0.5, 0.2, -0.1),
                    ..base
                },
                v(2e-4, -1e-4, 0.0),
            ),
        ),
        (
            "separating",
            c(
                ContactInput {
                    v_rel: v(0.3, 0.0, 5.0),
                    ..base
                },
                v(1e-5, 0.0, 0.0),
            ),
        ),
        ("spring along the normal", c(base, v(0.0, 0.0, 1e-5))),
        (
            "zero overlap",
            c(
                ContactInput {
                    overlap: 0.0,
                    ..base
                },
                v(1e-6, 0.0, 0.0),
            ),
        ),
        (
            "wall",
            c(
                ContactInput {
                    r_eff: 2.9e-3,
                    m_eff: 1.4e-4,
                    ..base
                },
                v(0.0, 3e-6, 0.0),
            ),
        ),
    ]
}

/// Random touching contacts: overlaps up to 5 % of d, velocities up to 1 m/s, springs up to
/// 0.1 mm (many beyond the Coulomb limit), some zero.
fn random(law: LawKernel<f32>, rng: &mut ChaCha8Rng, k: usize) -> ProbeContact {
    let mut u = |s: f32| s * (2.0 * rng.random::<f32>() - 1.0);
    let n = v(u(1.0), u(1.0), u(1.0) + 1.5);
    let n = n * (1.0 / n.norm());
    ProbeContact {
        law,
        input: ContactInput {
            overlap: 2.9e-4 * (0.5 + 0.5 * u(1.0)),
            normal: n,
            v_rel: v(u(1.0), u(1.0), u(1.0)),
            r_eff: 1.45e-3,
            m_eff: 7e-5 * (1.0 + 0.1 * u(1.0)),
        },
        spring: if k.is_multiple_of(3) {
            V3::zero()
        } else {
            v(u(1e-4), u(1e-4), u(1e-4))
        },
        dt: 1e-6,
    }
}

fn close(a: V3<f32>, b: V3<f32>) -> bool {
    let scale = f64::from(a.norm().max(b.norm()));
    let d = (a - b).to_f64();
    d.iter().all(|x| x.abs() <= TOL * scale)
}

#[test]
fn the_wgsl_law_gives_the_rust_laws_forces_springs_and_energies() {
    let Some(dev) = device() else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut table: Vec<(String, ProbeContact)> = Vec::new();
    for (name, law) in laws() {
        for (what, c) in named(law) {
            table.push((format!("{name}, {what}"), c));
        }
        for k in 0..200 {
            table.push((format!("{name}, random {k}"), random(law, &mut rng, k)));
        }
    }
    let contacts: Vec<ProbeContact> = table.iter().map(|t| t.1).collect();
    let gpu = probe_law(&dev, &contacts).expect("probe");
    let (mut sliding, mut sticking) = (0, 0);
    for ((what, c), g) in table.iter().zip(&gpu) {
        let mut spring = c.spring;
        let f = contact_force(&c.law, &c.input, &mut spring, c.dt);
        let u = elastic_energy(&c.law, c.input.overlap, c.input.r_eff, c.spring);
        assert!(f.is_finite() && g.force.is_finite(), "{what}: {f:?} {g:?}");
        assert!(
            close(f, g.force),
            "{what}: force {f:?} (CPU) {:?} (GPU)",
            g.force
        );
        assert!(
            close(spring, g.spring),
            "{what}: spring {spring:?} (CPU) {:?} (GPU)",
            g.spring
        );
        let du = f64::from(u - g.energy).abs();
        assert!(
            du <= TOL * f64::from(u.abs()),
            "{what}: energy {u} (CPU) {} (GPU)",
            g.energy
        );
        if c.law.tangential {
            let n = c.input.normal;
            let (fn_, ft) = (f.dot(n), (f - n * f.dot(n)).norm());
            if ft >= 0.5 * fn_.abs() * (1.0 - 1e-4) {
                sliding += 1;
            } else {
                sticking += 1;
            }
        }
    }
    // Both sides of the Coulomb limit are held against each other.
    assert!(
        sliding > 50 && sticking > 50,
        "{sliding} sliding, {sticking} sticking"
    );
}
