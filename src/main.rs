//! The `sweep` command: parses the command line and dispatches to one subcommand.

mod cli;

fn main() {
    // `sweep status | head`: a closed pipe ends the process quietly, as it ends `cat`. Rust
    // starts with SIGPIPE ignored, and println! then panics on the broken pipe.
    // SAFETY: restores the default disposition before any thread exists; no handler runs.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // First, while the process has one thread (it sets an environment variable).
    sweep::engine::gpu::quiet_headless_device_select();
    let code = match cli::run() {
        Ok(code) => code,
        Err(e) => {
            // A closed pipe (sweep status | head) is not an error.
            if e.chain().any(|c| {
                c.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
            }) {
                0
            } else {
                eprintln!("sweep: error: {e:#}");
                2
            }
        }
    };
    std::process::exit(code);
}
