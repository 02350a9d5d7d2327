//! Criterion benches of the CPU engine on the two bench scenes (`sweep::bench`): 20 steps of
//! N = 5 000 particles, f32 and f64, all cores. Throughput is reported per particle-step.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use sweep::engine::{Backend, CpuEngine};

fn engine_steps(c: &mut Criterion) {
    let mut g = c.benchmark_group("advance_20_steps");
    g.sample_size(10);
    for scene in ["silo-bed", "chute-bed"] {
        let sc = sweep::bench::scene(scene, 5_000, 1).expect("scene");
        let n = sc.state.len() as u64;
        g.throughput(Throughput::Elements(n * 20));
        let mut e32 = CpuEngine::<f32>::new(sc.config.clone(), sc.state.convert(), 0);
        e32.advance(50).expect("warm-up");
        g.bench_function(format!("{scene}/f32"), |b| {
            b.iter(|| e32.advance(20).expect("advance"))
        });
        let mut e64 = CpuEngine::<f64>::new(sc.config.clone(), sc.state.clone(), 0);
        e64.advance(50).expect("warm-up");
        g.bench_function(format!("{scene}/f64"), |b| {
            b.iter(|| e64.advance(20).expect("advance"))
        });
    }
    g.finish();
}

criterion_group!(benches, engine_steps);
criterion_main!(benches);
