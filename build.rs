//! How the `metamer` binary is linked (the library and the tests are built as cargo builds them).
//!
//! On Linux with the GNU toolchain the binary is linked at a fixed address (`-no-pie`): a
//! position-independent executable made the loader apply about 11 200 relocations at every start (the
//! addresses in the binary's tables of functions and constants, 270 KB of relocation records) and copy the
//! pages holding them; linked at a fixed address it has 160, and the same code (the libraries stay
//! position-independent, and so does where the heap, the stack and the shared libraries sit). Measured on
//! `metamer --version` (alternated pairs against the position-independent binary): 141 page faults
//! against 180 and 0.91 of its CPU time; see docs/solve_performance.md
//! ("Start-up, and the solved palette's entries").
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let var = |name: &str| std::env::var(name).unwrap_or_default();
    if var("CARGO_CFG_TARGET_OS") == "linux" && var("CARGO_CFG_TARGET_ENV") == "gnu" {
        println!("cargo:rustc-link-arg-bins=-no-pie");
    }
}
