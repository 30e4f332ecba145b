//! The command line against hostile and unlucky arguments (issue 31): every flag that takes a number
//! or a duration names itself when given a negative one, and a proptest target runs the `vkpath`
//! binary on random argument lists drawn from its flags and from values chosen to be wrong (negative,
//! zero, huge, not numbers, empty), with a fixed seed and a bounded number of cases so that CI runs it
//! in seconds. For every argument list: no panic and no signal, exit status 2 (or 0 for a valid list
//! whose scene is absent: never, here; or 1 for a device error: never, no render runs), one paragraph
//! on stderr beginning `vkpath:`, and nothing written in the directory.
//!
//! Nothing renders: the scene named is absent or the flags are refused first. `PROPTEST_CASES=N`
//! runs N cases instead of the default.

mod common;

use common::cli::run;
use common::fuzz::config;
use proptest::prelude::*;
use std::path::Path;

/// (flag, value) pairs that once got clap's "unexpected argument '-1'" without the flag: each must be
/// refused naming the flag.
#[test]
fn negative_values_name_their_flag() {
    let dir = tempfile::tempdir().unwrap();
    common::cli::write(
        dir.path(),
        "s.toml",
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[image]\nwidth = 8\nheight = 8\n\
         [materials]\nw = { type = \"diffuse\", albedo = [0.5, 0.5, 0.5] }\n\
         [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"w\"\n",
    );
    let cases: &[&[&str]] = &[
        &["render", "s.toml", "--roulette-depth", "-1"],
        &[
            "render",
            "s.toml",
            "--checkpoint",
            "c.ckpt",
            "--checkpoint-every",
            "-1",
        ],
        &["render", "s.toml", "--time", "-5s"],
        &["render", "s.toml", "--tile", "-4x4"],
        &["render", "s.toml", "--sample-range", "-1..4"],
        &["render", "s.toml", "--dispatch-ms", "-3"],
        &["render", "s.toml", "--seed", "-1"],
        &["bench", "mesh", "--brute-force-up-to", "-1"],
        &["bench", "mesh", "-1000"],
    ];
    for args in cases {
        let mut args = args.to_vec();
        if args[0] == "render" {
            args.extend(["-o", "out.png"]);
        }
        let out = run(dir.path(), &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        let flag = args
            .iter()
            .find(|a| a.starts_with("--") && !["--checkpoint"].contains(a))
            .copied()
            .unwrap_or("sizes");
        let named = if flag == "sizes" {
            stderr.contains("SIZES") || stderr.contains("sizes")
        } else {
            stderr.contains(flag)
        };
        assert!(
            named && !stderr.contains("unexpected argument"),
            "{args:?}: {stderr}"
        );
        assert!(!dir.path().join("out.png").exists());
    }
}

/// Values chosen to be wrong for most flags, and a few right ones.
const VALUES: &[&str] = &[
    "-1",
    "0",
    "1",
    "3",
    "64",
    "-0",
    "4294967296",
    "18446744073709551616",
    "1e99",
    "nan",
    "inf",
    "-inf",
    "",
    " ",
    "abc",
    "-",
    "--",
    "5s",
    "-5s",
    "0s",
    "1e9h",
    "10m",
    "0..4",
    "4..0",
    "0..0",
    "-1..3",
    "0..4294967296",
    "0/1",
    "1/0",
    "env",
    "env/0",
    "3/2",
    "64x64",
    "0x0",
    "1x-1",
    "albedo,normal",
    "bogus",
    "albedo,,",
    "off",
    "mis",
    "sobol",
    "x.png",
    "x.exr",
    "x.jpg",
    "c.ckpt",
    "absent.toml",
];

/// The flags of `render` (those taking a value, and switches).
const RENDER_FLAGS: &[(&str, bool)] = &[
    ("--spp", true),
    ("--time", true),
    ("--target-error", true),
    ("--seed", true),
    ("--width", true),
    ("--height", true),
    ("--max-bounces", true),
    ("--sampler", true),
    ("--light-sampling", true),
    ("--progress-every", true),
    ("--samples-per-pass", true),
    ("--casts-per-dispatch", true),
    ("--roulette-depth", true),
    ("--checkpoint", true),
    ("--checkpoint-every", true),
    ("--resume", true),
    ("--sample-range", true),
    ("--part", true),
    ("--aov", true),
    ("--tile", true),
    ("--dispatch-ms", true),
    ("--camera", true),
    ("-D", true),
    ("-o", true),
    ("--json", false),
    ("--quiet", false),
    ("--generic", false),
    ("--xml-lenient", false),
];

fn argument_list() -> impl Strategy<Value = Vec<String>> {
    let flag = (0..RENDER_FLAGS.len(), 0..VALUES.len()).prop_map(|(f, v)| {
        let (name, takes) = RENDER_FLAGS[f];
        if takes {
            vec![name.to_string(), VALUES[v].to_string()]
        } else {
            vec![name.to_string()]
        }
    });
    let command = prop_oneof![
        Just(vec!["render".to_string(), "absent.toml".to_string()]),
        Just(vec!["merge".to_string(), "absent.ckpt".to_string()]),
        Just(vec!["convert".to_string(), "absent.xml".to_string()]),
        Just(vec!["compare".to_string(), "a.png".to_string()]),
    ];
    (command, prop::collection::vec(flag, 0..5))
        .prop_map(|(c, flags)| c.into_iter().chain(flags.into_iter().flatten()).collect())
}

/// Whether `dir` holds anything.
fn is_empty(dir: &Path) -> bool {
    std::fs::read_dir(dir).unwrap().next().is_none()
}

proptest! {
    #![proptest_config(config(3000))]

    #[test]
    fn random_argument_lists_are_refused_in_one_paragraph(args in argument_list()) {
        let dir = tempfile::tempdir().unwrap();
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = run(dir.path(), &refs);
        let stderr = String::from_utf8_lossy(&out.stderr);
        // No render runs (the inputs are absent), so no device error either: exit 2.
        prop_assert_eq!(out.status.code(), Some(2), "{:?}: {}", args, stderr);
        prop_assert!(!stderr.contains("panicked"), "{:?}: {}", args, stderr);
        let text = stderr.trim_end();
        prop_assert!(
            text.starts_with("vkpath:") && !text.contains('\n'),
            "{:?}: one paragraph expected: {}", args, stderr
        );
        prop_assert!(is_empty(dir.path()), "{:?} wrote into its directory", args);
    }
}
