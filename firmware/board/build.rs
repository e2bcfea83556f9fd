//! Linker arguments for the Cortex-M image: `link.x` from cortex-m-rt (which includes the
//! `memory.x` that embassy-stm32's `memory-x` feature generates) and `defmt.x` for the logs.

fn main() {
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
