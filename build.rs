//! `FAST_REJECT_SKIP_GPU=1` at build time marks the tests that need a GPU
//! adapter as ignored, so that a machine without one reports them skipped,
//! not passed.

fn main() {
    println!("cargo::rustc-check-cfg=cfg(skip_gpu_tests)");
    println!("cargo::rerun-if-env-changed=FAST_REJECT_SKIP_GPU");
    if std::env::var("FAST_REJECT_SKIP_GPU").is_ok_and(|v| v == "1") {
        println!("cargo::rustc-cfg=skip_gpu_tests");
    }
}
