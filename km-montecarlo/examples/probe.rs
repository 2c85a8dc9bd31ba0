use km_montecarlo::*;
fn main() {
    let s = km_core::Scene::from_toml_str("[light]\ntheta_deg=60.0\n[[layer]]\ntau = 1.0\nalbedo = 0.9\n[output]\ndirections_deg=[[84.260829523,180.0],[84.260829523,0.0],[84.26,90.0],[60.0,0.0],[60.0,180.0]]\n").unwrap();
    for seed in [1u64, 2] {
        let o = McOptions { samples: 4_000_000, seed, ..Default::default() };
        let sol = solve(&s, &o).unwrap();
        let c = &sol.channels[0];
        println!("{:?}\n{:?}", c.brdf, c.stderr.as_ref().unwrap()["brdf"]);
    }
}
