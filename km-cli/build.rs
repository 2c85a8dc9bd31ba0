//! Builds `km fit --km` in when `src/fit_km.rs` (the Kubelka–Munk inverse's
//! command-line side) is present: sets `cfg(km_fit_km)`.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(km_fit_km)");
    println!("cargo::rerun-if-changed=src");
    if std::path::Path::new("src/fit_km.rs").exists() {
        println!("cargo::rustc-cfg=km_fit_km");
    }
}
