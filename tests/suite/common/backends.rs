//! The backends the physical contracts run on. A contract is written once as a function of
//! `&On`: it builds its scene, runs it on `On::build` through `&mut dyn Backend` and checks it.
//! `per_backend!` runs it on the CPU engine (f64) always and on the GPU engine (f32) where
//! `gpu::device()` gives a device.

use sweep::engine::gpu::GpuDevice;
use sweep::engine::{Backend, CpuEngine, EngineConfig, State};

/// The backend a contract runs on.
pub enum On {
    /// `CpuEngine<f64>`, one thread.
    Cpu,
    /// `GpuEngine` (f32) on the shared device (boxed: it is large).
    Gpu(Box<GpuDevice>),
}

impl On {
    pub fn build(&self, config: &EngineConfig, s: &State<f64>) -> Box<dyn Backend> {
        match self {
            On::Cpu => Box::new(CpuEngine::<f64>::new(config.clone(), s.clone(), 1)),
            On::Gpu(dev) => Box::new(super::gpu::engine(dev, config, s)),
        }
    }

    /// `cpu` on the CPU, `gpu` on the GPU: where f32 rounding sets another tolerance, or a
    /// shorter run keeps lavapipe's time down.
    pub fn pick<T>(&self, cpu: T, gpu: T) -> T {
        match self {
            On::Cpu => cpu,
            On::Gpu(_) => gpu,
        }
    }

    pub fn name(&self) -> &'static str {
        self.pick("CPU f64", "GPU")
    }
}

/// `per_backend!(name, …)`: for each contract `fn name(on: &On)` of the calling module, the
/// tests `cpu::name` and `gpu::name`; the GPU one passes at once without an adapter outside CI.
macro_rules! per_backend {
    ($($(#[$attr:meta])* $name:ident),* $(,)?) => {
        mod cpu {
            $(
                $(#[$attr])*
                #[test]
                fn $name() {
                    super::$name(&$crate::common::backends::On::Cpu)
                }
            )*
        }
        mod gpu {
            $(
                $(#[$attr])*
                #[test]
                fn $name() {
                    let Some(dev) = $crate::common::gpu::device() else { return };
                    super::$name(&$crate::common::backends::On::Gpu(Box::new(dev)))
                }
            )*
        }
    };
}
pub(crate) use per_backend;
