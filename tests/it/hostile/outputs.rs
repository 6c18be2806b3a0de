//! Outputs that must not replace what they should not (issue: "never replace an input of the running
//! command, a file changed since it was read, a read-only file, or a file reached through a link the
//! command did not create, without an explicit flag"): the one writer's rules, driven through the real
//! binary where the issue does.

use super::{metamer, stderr};
use crate::common::random;
use metamer::colorimetry::Colorimetry;
use metamer::fsio::{self, FsError, Replace};
use metamer::palette::PaletteFile;
use std::path::Path;
use std::time::{Duration, Instant};

fn no_temporary_files(d: &Path) {
    let left: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

#[test]
fn a_file_changed_since_it_was_read_is_not_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.toml");
    std::fs::write(&path, super::SMALL).unwrap();
    let mut file = PaletteFile::load(&path).unwrap();
    let palette = file.palette.clone();
    // Another program rewrites the file after it was read.
    let outside = super::SMALL.replace("#806040", "#204080");
    std::fs::write(&path, &outside).unwrap();
    let refused = file.stage_save_as(&palette, &path, Replace::Writable);
    let e = refused.err().expect("the outside change is not replaced");
    assert!(e.to_string().contains("changed on disk since this command read it"), "{e}");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), outside);
    no_temporary_files(dir.path());
    // The same through the plain writer (every command's outputs go through it).
    assert!(matches!(fsio::write_atomic(&path, b"x"), Err(FsError::Changed { .. })));
    // Told that the user chose to overwrite it, it does; then what was written counts as read, so the
    // next save needs no flag.
    let staged = file.stage_save_as(&palette, &path, Replace::Changed).unwrap();
    file.commit(staged).unwrap();
    assert_ne!(std::fs::read_to_string(&path).unwrap(), outside);
    file.save(&palette).expect("a save over what this process wrote");
    // A change of times alone (`touch`) is not a change: the content is what was read.
    let later = std::time::SystemTime::now() + Duration::from_secs(5);
    std::fs::File::options().write(true).open(&path).unwrap().set_modified(later).unwrap();
    file.save(&palette).expect("touch is not a change");
    // A file that was never read is replaced as before.
    let other = dir.path().join("q.toml");
    std::fs::write(&other, "old").unwrap();
    fsio::write_atomic(&other, b"new").unwrap();
}

#[test]
fn solve_in_place_never_loses_an_edit_made_while_it_ran() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A palette large enough that the edit usually lands while the solve runs (reading, solving or writing).
    let palette = random::batch_palette(6000, 3, &Colorimetry::default());
    PaletteFile::from_palette(&palette).save_as(&palette, &d.join("p.toml")).unwrap();
    let original = std::fs::read_to_string(d.join("p.toml")).unwrap();
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_metamer"))
        .current_dir(d)
        .args(["solve", "p.toml", "-o", "p.toml", "-q", "--no-subspace"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(60));
    // The edit replaces the file whole, as editors save (no half-written file for the solve to read).
    let mut text = std::fs::read_to_string(d.join("p.toml")).unwrap();
    let solved_before_the_edit = text != original;
    text.push_str("\n# an edit made while the solve ran\n");
    std::fs::write(d.join("p.edit"), &text).unwrap();
    std::fs::rename(d.join("p.edit"), d.join("p.toml")).unwrap();
    let o = child.wait_with_output().unwrap();
    let after = std::fs::read_to_string(d.join("p.toml")).unwrap();
    // Whichever way the race went, the edit survives (comments are kept): the solve had written before the
    // edit (the edit was made to its output), or it read the edited file and solved it, or it had read the
    // file before the edit and refuses to replace it, saying why.
    assert!(after.contains("# an edit made while the solve ran"), "the edit was overwritten");
    if o.status.success() {
        assert!(
            solved_before_the_edit || after != text,
            "a successful solve that had not written before the edit solved the edited file"
        );
    } else {
        assert!(stderr(&o).contains("changed on disk since this command read it"), "{}", stderr(&o));
        assert_eq!(after, text, "nothing was written");
    }
    no_temporary_files(d);
    // --force replaces it.
    let o = metamer(d, &["solve", "p.toml", "-o", "p.toml", "-q", "--no-subspace", "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn render_does_not_write_through_a_link_in_its_output_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    super::inputs::scene_dir(d, "v.raw");
    std::fs::create_dir(d.join("out")).unwrap();
    std::fs::write(d.join("victim.txt"), "mine\n").unwrap();
    std::os::unix::fs::symlink("../victim.txt", d.join("out/frame_0001.png")).unwrap();
    let render = |extra: &[&str]| {
        let mut args = vec!["render", "s.toml", "--frames", "2", "--size", "8"];
        args.extend_from_slice(extra);
        metamer(d, &args)
    };
    let start = Instant::now();
    let o = render(&["-o", "out"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("refusing to write through a symbolic link this command did not make"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("--force"), "{}", stderr(&o));
    assert!(start.elapsed() < Duration::from_secs(20));
    assert_eq!(std::fs::read_to_string(d.join("victim.txt")).unwrap(), "mine\n");
    assert!(!d.join("out/frame_0000.png").exists(), "refused before any frame was written");
    // A contact sheet the user named is theirs to point anywhere: the link is followed and kept.
    std::fs::write(d.join("real.png"), "old").unwrap();
    std::os::unix::fs::symlink("real.png", d.join("sheet.png")).unwrap();
    let o = render(&["-o", "other", "--contact-sheet", "sheet.png"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::symlink_metadata(d.join("sheet.png")).unwrap().file_type().is_symlink());
    assert!(std::fs::read(d.join("real.png")).unwrap().starts_with(b"\x89PNG"));
    // With --force the frame's link is written through, and kept.
    let o = render(&["-o", "out", "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::symlink_metadata(d.join("out/frame_0001.png")).unwrap().file_type().is_symlink());
    assert!(std::fs::read(d.join("victim.txt")).unwrap().starts_with(b"\x89PNG"));
}

#[test]
fn a_sidecar_is_never_written_over_a_csv_the_palette_reads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The palette reads its measured reflectance from the very file its basis sidecar would be.
    let palette = format!("{}\n[[reflectances]]\nname = \"m\"\ncsv = \"p.basis.json\"\n", super::SMALL);
    std::fs::write(d.join("p.toml"), &palette).unwrap();
    std::fs::write(d.join("p.basis.json"), super::inputs::csv()).unwrap();
    let o = metamer(d, &["basis", "p.toml", "-m", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("not stored") && out.contains("same file as the CSV spectrum"), "{out}");
    assert_eq!(std::fs::read_to_string(d.join("p.basis.json")).unwrap(), super::inputs::csv());
    assert_eq!(std::fs::read_to_string(d.join("p.toml")).unwrap(), palette);
    no_temporary_files(d);
}

#[test]
fn designer_save_as_never_lands_on_its_scene_or_its_key_script() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    super::inputs::scene_dir(d, "v.raw");
    std::fs::write(d.join("other.toml"), super::SMALL).unwrap();
    let scene = std::fs::read(d.join("s.toml")).unwrap();
    for target in ["s.toml", "keys.txt"] {
        // Save as the target, and Enter again to answer the "replace it?" question.
        let keys = format!("wait-solve\nCtrl-w\nCtrl-u\n\"{target}\"\nEnter\nEnter\n");
        std::fs::write(d.join("keys.txt"), &keys).unwrap();
        let o = metamer(
            d,
            &[
                "design",
                "other.toml",
                "--scene",
                "s.toml",
                "--no-basis",
                "--size",
                "120x40",
                "--replay",
                "keys.txt",
                "--screen",
                "screen.txt",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let screen = std::fs::read_to_string(d.join("screen.txt")).unwrap();
        assert!(screen.contains("refusing to write the palette"), "{target}: {screen}");
        assert_eq!(std::fs::read(d.join("s.toml")).unwrap(), scene, "the scene is kept");
        assert_eq!(std::fs::read_to_string(d.join("keys.txt")).unwrap(), keys, "the key script is kept");
        assert_eq!(std::fs::read_to_string(d.join("other.toml")).unwrap(), super::SMALL);
    }
}

#[test]
fn bench_replaces_only_its_own_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("README.md"), "# my project\n").unwrap();
    std::fs::write(d.join("victim.txt"), "mine\n").unwrap();
    // `-o .` in a project folder: its README.md is not the benchmark's.
    let start = Instant::now();
    let o = metamer(d, &["bench", "solve", "--quick", "-o", "."]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("refusing to replace a file `metamer bench` did not write"), "{}", stderr(&o));
    assert!(start.elapsed() < Duration::from_secs(5), "refused before it ran");
    assert_eq!(std::fs::read_to_string(d.join("README.md")).unwrap(), "# my project\n");
    // A run into its own folder, then again: its own files (marked) are replaced.
    let o = metamer(d, &["bench", "solve", "--quick", "-o", "b"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = metamer(d, &["bench", "solve", "--quick", "-o", "b"]);
    assert!(o.status.success(), "the second run replaces its own files: {}", stderr(&o));
    // A link in its folder, at one of its names, is not followed.
    std::fs::remove_file(d.join("b/solve.md")).unwrap();
    std::os::unix::fs::symlink("../victim.txt", d.join("b/solve.md")).unwrap();
    let o = metamer(d, &["bench", "solve", "--quick", "-o", "b"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("symbolic link"), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(d.join("victim.txt")).unwrap(), "mine\n");
    // --force replaces the project's README.md.
    let o = metamer(d, &["bench", "solve", "--quick", "-o", ".", "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(d.join("README.md")).unwrap().contains(metamer::bench::MD_MARK));
}
