//! The GPU device shared by the tests of one test crate: acquired once, on any adapter (lavapipe
//! included). Without an adapter the tests print a message and pass, except under CI=true, where a
//! missing adapter fails them.

use std::sync::OnceLock;

use sweep::engine::gpu::{AdapterPolicy, GpuDevice};

/// The shared device, or None (with a message) when there is no adapter outside CI.
pub fn device() -> Option<GpuDevice> {
    static DEV: OnceLock<Option<GpuDevice>> = OnceLock::new();
    DEV.get_or_init(|| {
        if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
            // Mesa complains without it; a private directory keeps it quiet.
            let dir = tempfile::tempdir().expect("temp dir").keep();
            std::env::set_var("XDG_RUNTIME_DIR", dir);
        }
        match GpuDevice::acquire(AdapterPolicy::Any) {
            Ok(d) => Some(d),
            Err(e) if std::env::var("CI").as_deref() == Ok("true") => {
                panic!("CI=true and no usable GPU adapter: {e}")
            }
            Err(e) => {
                eprintln!("skipping GPU tests: {e}");
                None
            }
        }
    })
    .clone()
}
