//! Never destroy what tprf did not write: every command that writes a folder replaces
//! only a new path, an empty folder or an earlier tprf output holding nothing else.
//! Each case builds what stands at `--out` itself, in a temporary folder (never the
//! system's files), and checks that it survives byte for byte and that the message
//! names the problem.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn tprf_in(cwd: Option<&Path>, args: &[&str]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_tprf"));
    c.args(args);
    if let Some(d) = cwd {
        c.current_dir(d);
    }
    c.output().expect("run tprf")
}

fn tprf(args: &[&str]) -> Output {
    tprf_in(None, args)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn tempdir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("never-destroy-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A tiny render of the Cornell box into `out`.
fn render(out: &Path) -> Output {
    tprf(&[
        "render",
        "builtin:cornell",
        "--out",
        out.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "6",
        "--spp",
        "2",
        "--bins",
        "16",
    ])
}

/// Every file under `dir` (relative path, bytes), sorted: what must survive.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(PathBuf, Vec<u8>)>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let m = std::fs::symlink_metadata(&p).unwrap();
            if m.is_dir() {
                walk(root, &p, out);
            } else if m.is_file() {
                out.push((
                    p.strip_prefix(root).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                ));
            } else {
                out.push((p.strip_prefix(root).unwrap().to_path_buf(), Vec::new()));
            }
        }
    }
    let mut v = Vec::new();
    walk(dir, dir, &mut v);
    v.sort();
    v
}

/// The command failed, and its message has every one of `words`.
fn refused(o: &Output, words: &[&str]) {
    assert!(!o.status.success(), "should have been refused");
    let e = stderr(o);
    for w in words {
        assert!(e.contains(w), "message lacks {w:?}: {e}");
    }
}

#[test]
fn a_user_folder_is_refused_and_kept() {
    let dir = tempdir("user");
    let proj = dir.join("proj");
    std::fs::create_dir(&proj).unwrap();
    std::fs::write(proj.join("thesis.tex"), b"\\documentclass{article}").unwrap();
    std::fs::create_dir(proj.join("figures")).unwrap();
    std::fs::write(proj.join("figures/a.png"), b"png").unwrap();
    let before = snapshot(&dir);
    let o = render(&proj);
    refused(
        &o,
        &[
            "--out",
            "proj",
            "holds files tprf did not write",
            "thesis.tex",
            "choose a new or empty folder",
        ],
    );
    assert_eq!(snapshot(&dir), before, "the user's folder changed");
}

#[test]
fn a_regular_file_is_refused_and_kept() {
    let dir = tempdir("file");
    let f = dir.join("somefile");
    std::fs::write(&f, b"precious").unwrap();
    let o = render(&f);
    refused(&o, &["somefile", "is a file"]);
    assert_eq!(std::fs::read(&f).unwrap(), b"precious");
    assert!(std::fs::symlink_metadata(&f).unwrap().is_file());
}

#[cfg(unix)]
#[test]
fn a_fifo_a_socket_and_a_device_node_are_refused_and_kept() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempdir("special");
    let fifo = dir.join("fifo");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: `c` is a NUL-terminated path that outlives the call.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
    let o = render(&fifo);
    refused(&o, &["fifo", "named pipe"]);
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo()
    );

    let sock = dir.join("sock");
    let _listener = std::os::unix::net::UnixListener::bind(&sock).unwrap();
    let o = render(&sock);
    refused(&o, &["sock", "socket"]);
    assert!(
        std::fs::symlink_metadata(&sock)
            .unwrap()
            .file_type()
            .is_socket()
    );

    // A character device like /dev/full (1, 7), made in the temporary folder: only
    // root may; elsewhere this part is skipped.
    let dev = dir.join("full");
    let c = std::ffi::CString::new(dev.to_str().unwrap()).unwrap();
    // SAFETY: `c` is a NUL-terminated path that outlives the call.
    if unsafe { libc::mknod(c.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 7)) } == 0 {
        let o = render(&dev);
        refused(&o, &["full", "character device"]);
        assert!(
            std::fs::symlink_metadata(&dev)
                .unwrap()
                .file_type()
                .is_char_device()
        );
    } else {
        eprintln!("note: mknod not permitted here; the device-node case was skipped");
    }
}

#[cfg(unix)]
#[test]
fn a_symlinked_out_is_refused_and_neither_link_nor_target_changes() {
    let dir = tempdir("link");
    // A link to an earlier tprf output, and one to a user's folder.
    let real = dir.join("real");
    assert!(render(&real).status.success());
    let user = dir.join("user");
    std::fs::create_dir(&user).unwrap();
    std::fs::write(user.join("notes.txt"), b"mine").unwrap();
    for target in [&real, &user] {
        let link = dir.join(format!(
            "link-{}",
            target.file_name().unwrap().to_str().unwrap()
        ));
        std::os::unix::fs::symlink(target, &link).unwrap();
        let before = snapshot(&dir);
        let o = render(&link);
        refused(
            &o,
            &["symbolic link", "never replaces what a link points to"],
        );
        assert_eq!(snapshot(&dir), before);
        assert_eq!(std::fs::read_link(&link).unwrap(), *target);
    }
}

#[test]
fn the_current_folder_and_the_one_above_are_refused() {
    let dir = tempdir("dot");
    let here = dir.join("here");
    std::fs::create_dir(&here).unwrap();
    for out in [".", "..", "./", "../here"] {
        let before = snapshot(&dir);
        let o = tprf_in(
            Some(&here),
            &[
                "render",
                "builtin:cornell",
                "--out",
                out,
                "--width",
                "4",
                "--height",
                "4",
                "--spp",
                "1",
            ],
        );
        refused(&o, &["current folder", "name a new folder"]);
        assert_eq!(snapshot(&dir), before, "--out {out}");
    }
}

#[cfg(target_os = "linux")]
#[test]
fn a_mount_point_is_refused() {
    // /proc is a mount point on every Linux; nothing is written to it.
    let o = render(Path::new("/proc"));
    refused(&o, &["/proc", "mount point"]);
}

#[test]
fn an_earlier_output_is_replaced_but_not_with_a_users_file_in_it() {
    let dir = tempdir("rerender");
    let out = dir.join("cube");
    assert!(render(&out).status.success());
    assert!(out.join(".tprf-output.json").is_file());
    // Replaced whole: a second render into it works and keeps only its own files.
    assert!(render(&out).status.success(), "re-render into own output");
    // A file the user added is never deleted: the run is refused, naming it.
    std::fs::write(out.join("notes.txt"), b"what I saw").unwrap();
    let before = snapshot(&dir);
    let o = render(&out);
    refused(
        &o,
        &[
            "earlier tprf output",
            "notes.txt",
            "move them out first, or choose a new or empty folder",
        ],
    );
    assert_eq!(snapshot(&dir), before);
    // Moved out, the re-render goes through.
    std::fs::remove_file(out.join("notes.txt")).unwrap();
    assert!(render(&out).status.success());
}

#[test]
fn an_output_written_before_manifests_is_recognised_by_its_metadata() {
    let dir = tempdir("legacy");
    let out = dir.join("cube");
    assert!(render(&out).status.success());
    std::fs::remove_file(out.join(".tprf-output.json")).unwrap();
    assert!(render(&out).status.success(), "a legacy cube folder");
    // A tprf.json that is not a cube's does not make a folder tprf's.
    let fake = dir.join("fake");
    std::fs::create_dir(&fake).unwrap();
    std::fs::write(fake.join("tprf.json"), br#"{"format": "my own"}"#).unwrap();
    let o = render(&fake);
    refused(&o, &["holds files tprf did not write", "tprf.json"]);
    assert!(fake.join("tprf.json").is_file());
}

#[test]
fn sensor_merge_converge_and_stability_refuse_a_user_folder() {
    let dir = tempdir("others");
    let cube = dir.join("cube");
    assert!(render(&cube).status.success());
    let user = dir.join("user");
    std::fs::create_dir(&user).unwrap();
    std::fs::write(user.join("data.csv"), b"1,2,3").unwrap();
    let before = snapshot(&dir);
    let (cube_s, user_s) = (cube.to_str().unwrap(), user.to_str().unwrap());
    let runs: [&[&str]; 4] = [
        &[
            "sensor",
            cube_s,
            "--preset",
            "builtin:lidar",
            "--out",
            user_s,
        ],
        &["merge", user_s, cube_s],
        &[
            "converge",
            "--reference",
            "analytic:plane",
            "--seconds",
            "1",
            "--out",
            user_s,
        ],
        &["stability", "--size", "test", "--out", user_s],
    ];
    for args in runs {
        let o = tprf(args);
        refused(&o, &["data.csv", "choose a new or empty folder"]);
        assert_eq!(snapshot(&dir), before, "{args:?}");
    }
    // A sensor run never replaces the cube it reads.
    let o = tprf(&[
        "sensor",
        cube_s,
        "--preset",
        "builtin:lidar",
        "--out",
        cube_s,
    ]);
    refused(&o, &["which this command reads"]);
    assert_eq!(snapshot(&dir), before);
    // Into a new folder, and again into its own output, it works.
    let meas = dir.join("lidar");
    for _ in 0..2 {
        let o = tprf(&[
            "sensor",
            cube_s,
            "--preset",
            "builtin:lidar",
            "--out",
            meas.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert!(meas.join("sensor.npy").is_file());
}

#[test]
fn an_output_folder_inside_a_cube_folder_is_kept_as_tprf_s() {
    // tprf batch measures into CUBE/sensor-NAME: a re-render of the cube replaces both,
    // since both are tprf's; a user file inside the sensor folder stops it.
    let dir = tempdir("nested");
    let cube = dir.join("cube");
    assert!(render(&cube).status.success());
    let cube_s = cube.to_str().unwrap();
    let sensor = cube.join("sensor-lidar");
    let o = tprf(&[
        "sensor",
        cube_s,
        "--preset",
        "builtin:lidar",
        "--out",
        sensor.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::write(sensor.join("mine.txt"), b"x").unwrap();
    let before = snapshot(&dir);
    refused(&render(&cube), &["sensor-lidar"]);
    assert_eq!(snapshot(&dir), before);
    std::fs::remove_file(sensor.join("mine.txt")).unwrap();
    assert!(render(&cube).status.success());
    assert!(
        !sensor.exists(),
        "the old measurement went with the old cube"
    );
}
