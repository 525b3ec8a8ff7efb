//! Temporary.
fn main() {
    let opts = hom_walk::bench::BenchOptions { frames: Some(30), width: Some(512), height: Some(512), threads: 0 };
    let r = hom_walk::bench::run_bench(&["city", "spheres"], &["none", "frustum", "hom"], &opts, |m| eprintln!("{m}")).unwrap();
    print!("{}", r.table());
    hom_walk::pictures::plot_stage_breakdown(std::path::Path::new("/tmp/hom-walk-pictures-test/bench_stages.png"), &r.stage_bars()).unwrap();
    println!("{}", serde_json::to_string(&r.rows[2]).unwrap());
}
