//! `twinray bench-stereo` times the views against the same views rendered
//! alone: each view a mono render of its own camera (the eye moved by the
//! view's offset, the view's whole-pixel image shift). The exact method's
//! views must equal those renders bit for bit, or the command fails, so a
//! baseline that rendered other views (the rig's centre, or no image shift)
//! is caught here.

use std::path::PathBuf;
use std::process::Command;

fn scene() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

#[test]
fn the_baseline_is_each_view_rendered_alone() {
    let scene = scene();
    // Converged at the 'at' point (the default with a numeric interaxial):
    // at 48x48 the views' image shifts are whole pixels apart, not zero.
    for views in ["2", "3"] {
        let out = Command::new(env!("CARGO_BIN_EXE_twinray"))
            .arg("bench-stereo")
            .arg(&scene)
            .args(["--sizes", "48", "--interaxial", "0.4", "--runs", "1"])
            .args(["--views", views, "--approx", "none,fast"])
            .output()
            .expect("cannot start the twinray binary");
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert!(out.status.success(), "{views} views: {stderr}\n{stdout}");
        assert!(
            stdout.contains("| views alone (s) | views (s) | views / views alone |"),
            "{stdout}"
        );
        let row = |approx: &str| {
            stdout
                .lines()
                .find(|l| l.contains(&format!("| {approx} |")))
                .unwrap_or_else(|| panic!("no {approx} row:\n{stdout}"))
                .to_string()
        };
        // The exact views are the views rendered alone (the PSNR column).
        assert!(row("none").contains("| exact |"), "{}", row("none"));
        assert!(!row("fast").is_empty());
    }
}
