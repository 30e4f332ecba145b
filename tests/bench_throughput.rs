//! `vkpath bench throughput` on a directory of two tiny scenes: one row per scene in name order, the
//! median between the min and the max, JSON rows that say the same, and exit 2 for bad flags.

mod common;

use common::cli::run;

const SCENE: &str = r#"[camera]
position = [0.0, 0.0, 30.0]
look_at  = [0.0, 0.0, 0.0]
fov      = 50.0

[image]
width  = 64
height = 48

[render]
samples     = 4
max_bounces = 2

[materials]
white = { type = "diffuse", albedo = [0.8, 0.8, 0.8] }

[[sphere]]
center   = [0.0, 0.0, 0.0]
radius   = 8.0
material = "white"

[[light]]
type     = "point"
position = [10.0, 30.0, 30.0]
power    = 40000.0
"#;

#[test]
fn throughput_table_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let scenes = dir.path().join("scenes");
    std::fs::create_dir(&scenes).unwrap();
    std::fs::write(scenes.join("b.toml"), SCENE).unwrap();
    std::fs::write(scenes.join("a.toml"), SCENE).unwrap();
    std::fs::write(scenes.join("notes.txt"), "not a scene").unwrap();
    let args = [
        "bench",
        "throughput",
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "2",
        "--runs",
        "3",
    ];
    let out = run(dir.path(), &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.starts_with("Throughput, 8x8, 2 spp per timed pass, 3 runs, on "),
        "{stdout}"
    );
    let rows: Vec<Vec<&str>> = stdout
        .lines()
        .filter(|l| l.starts_with("| ") && l.contains(".toml"))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    assert_eq!(rows.len(), 2, "{stdout}");
    assert_eq!((rows[0][0], rows[1][0]), ("a.toml", "b.toml"));
    for r in &rows {
        assert_eq!(r[1], "2");
        let v: Vec<f64> = r[2..5].iter().map(|x| x.parse().unwrap()).collect();
        let (median, min, max) = (v[0], v[1], v[2]);
        assert!(min > 0.0 && min <= median && median <= max, "{r:?}");
    }

    let mut json_args = args.to_vec();
    json_args.push("--json");
    let out = run(dir.path(), &json_args);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    for r in rows {
        let m = r["median_samples_per_second"].as_f64().unwrap();
        let lo = r["min_samples_per_second"].as_f64().unwrap();
        let hi = r["max_samples_per_second"].as_f64().unwrap();
        assert!(lo > 0.0 && lo <= m && m <= hi, "{r}");
        // lavapipe runs the passes on this process's threads: they take CPU time.
        let cpu = r["min_cpu_seconds_per_msample"].as_f64().unwrap();
        assert!(cpu > 0.0 && cpu.is_finite(), "{r}");
        assert_eq!(r["spp"], 2);
    }

    let out = run(dir.path(), &["bench", "throughput", "--runs", "0"]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--runs"), "{stderr}");
    let empty = tempfile::tempdir().unwrap();
    std::fs::create_dir(empty.path().join("scenes")).unwrap();
    let out = run(empty.path(), &["bench", "throughput"]);
    assert_eq!(out.status.code(), Some(2));
}
