//! A stereo pair of the bundled example scene through the library's job API,
//! as red-cyan anaglyph: `cargo run --example stereo_pair -p twinray -- out.png`.

use twinray::job::{CancelToken, Job, JobSpec, LayoutSpec, Level};

fn main() -> twinray::Result<()> {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "stereo_pair.png".into());
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/example.nff");
    let mut spec = JobSpec::new(scene, out);
    spec.camera.size = Some([480, 360]);
    spec.rig.stereo = true; // interaxial and convergence fitted to the depth budget
    spec.output.layout = LayoutSpec::Anaglyph;

    let progress = |done: u64, total: u64| eprint!("\r{done}/{total} rows");
    let (written, messages) = Job::run(spec, &progress, &CancelToken::new())?;
    eprintln!();
    for m in messages.iter().filter(|m| m.level != Level::Info) {
        eprintln!("{:?}: {}", m.level, m.text);
    }
    for path in written {
        println!("wrote {}", path.display());
    }
    Ok(())
}
