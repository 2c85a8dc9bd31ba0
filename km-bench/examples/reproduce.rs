//! Run the reproduction from the library: `cargo run --release -p km-bench
//! --example reproduce -- [--quick | --full | --tiny] [OUT_DIR]` (default
//! quick, `out/`). `km reproduce` is the usual entry point.

fn main() -> anyhow::Result<()> {
    let mut opts = km_bench::ReproduceOptions::quick("out");
    for a in std::env::args().skip(1) {
        match a.as_str() {
            "--quick" => opts.quick = true,
            "--full" => opts.quick = false,
            "--tiny" => opts.tiny = true,
            dir => opts.out_dir = dir.into(),
        }
    }
    let summary = km_bench::reproduce(&opts)?;
    print!("{summary}");
    Ok(())
}
