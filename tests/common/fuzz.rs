//! Fuzzing helpers shared by the fuzz targets (tests/fuzz_scene.rs, fuzz_cli.rs, gltf.rs, mitsuba.rs):
//! proptest configured with a fixed seed and a bounded number of cases (so that CI is reproducible and
//! takes seconds; `PROPTEST_CASES=N` and `PROPTEST_RNG_SEED=S` change them), a watchdog that turns a
//! hang into a failure, and the mutations of a valid input (text or bytes) with boundary numbers.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use std::sync::mpsc;
use std::time::Duration;

/// The default seed of every target (a fixed one: CI runs are reproducible).
const SEED: u64 = 0x766b_7061_7468;

/// A proptest configuration of `default_cases` cases (or `PROPTEST_CASES`), fixed seed, no persistence.
pub fn config(default_cases: u32) -> Config {
    let mut c = Config {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default_cases),
        failure_persistence: None,
        ..Config::default()
    };
    if c.rng_seed == RngSeed::Random {
        c.rng_seed = RngSeed::Fixed(SEED);
    }
    c
}

/// Longer than any parse here takes (they take microseconds to milliseconds), short enough to call a
/// case that exceeds it a hang.
pub const WATCHDOG: Duration = Duration::from_secs(10);

/// Runs `f` on another thread and fails the case if it does not return within the watchdog (a panic
/// in `f` fails the case too, with its message).
pub fn within_watchdog<T: Send + 'static>(what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    let handle = std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    match rx.recv_timeout(WATCHDOG) {
        Ok(v) => {
            let _ = handle.join();
            v
        }
        Err(mpsc::RecvTimeoutError::Timeout) => {
            panic!("{what}: no answer after {WATCHDOG:?} (a hang)")
        }
        Err(mpsc::RecvTimeoutError::Disconnected) => match handle.join() {
            Err(p) => std::panic::resume_unwind(p),
            Ok(()) => panic!("{what}: the parser thread ended without an answer"),
        },
    }
}

/// The punctuation of JSON, for the targets whose inputs are JSON (glTF, a checkpoint's header).
pub const JSON_STRUCTURE: &[&str] = &["{", "}", "[", "]", ",", ":", "\"", "null"];

/// Numbers that sit on the validation boundaries or outside f32/u32.
pub const EXTREMES: &[&str] = &[
    "0",
    "-0",
    "1",
    "-1",
    "0.0",
    "1e-45",
    "1e-38",
    "3.4028235e38",
    "3.5e38",
    "1e308",
    "inf",
    "nan",
    "65535",
    "65536",
    "65537",
    "268435456",
    "4294967295",
    "4294967296",
    "-2147483649",
    "180",
    "1e5",
];

#[derive(Clone, Debug)]
pub enum Mutation {
    Delete { at: usize, len: usize },
    Insert { at: usize, token: usize },
    InsertBytes { at: usize, bytes: Vec<u8> },
    ReplaceNumber { nth: usize, with: usize },
    DuplicateLine { nth: usize, times: usize },
    SwapLines { a: usize, b: usize },
    Truncate { at: usize },
    FlipBit { at: usize, bit: u8 },
}

pub fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1usize..40).prop_map(|(at, len)| Mutation::Delete { at, len }),
        (any::<usize>(), any::<usize>()).prop_map(|(at, token)| Mutation::Insert { at, token }),
        (
            any::<usize>(),
            proptest::collection::vec(any::<u8>(), 1..16)
        )
            .prop_map(|(at, bytes)| Mutation::InsertBytes { at, bytes }),
        (any::<usize>(), any::<usize>())
            .prop_map(|(nth, with)| Mutation::ReplaceNumber { nth, with }),
        (any::<usize>(), 1usize..50)
            .prop_map(|(nth, times)| Mutation::DuplicateLine { nth, times }),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines { a, b }),
        any::<usize>().prop_map(|at| Mutation::Truncate { at }),
        (any::<usize>(), 0u8..8).prop_map(|(at, bit)| Mutation::FlipBit { at, bit }),
    ]
}

pub fn apply(text: &mut Vec<u8>, m: &Mutation, tokens: &[&str], extremes: &[&str]) {
    let n = text.len();
    let pos = |at: usize| if n == 0 { 0 } else { at % (n + 1) };
    match m {
        Mutation::Delete { at, len } => {
            let a = pos(*at).min(n);
            let b = (a + len).min(n);
            text.drain(a..b);
        }
        Mutation::Insert { at, token } => {
            let a = pos(*at);
            let t = tokens[token % tokens.len()].as_bytes();
            text.splice(a..a, t.iter().copied());
        }
        Mutation::InsertBytes { at, bytes } => {
            let a = pos(*at);
            text.splice(a..a, bytes.iter().copied());
        }
        Mutation::ReplaceNumber { nth, with } => {
            // The nth run of digits (with its sign, point and exponent) becomes an extreme value.
            let mut runs = Vec::new();
            let mut i = 0;
            while i < n {
                if text[i].is_ascii_digit() {
                    let mut a = i;
                    if a > 0 && (text[a - 1] == b'-' || text[a - 1] == b'+') {
                        a -= 1;
                    }
                    let mut b = i;
                    while b < n && (text[b].is_ascii_digit() || b".eE+-_".contains(&text[b])) {
                        b += 1;
                    }
                    runs.push((a, b));
                    i = b;
                } else {
                    i += 1;
                }
            }
            if !runs.is_empty() {
                let (a, b) = runs[nth % runs.len()];
                let e = extremes[with % extremes.len()].as_bytes();
                text.splice(a..b, e.iter().copied());
            }
        }
        Mutation::DuplicateLine { nth, times } => {
            let lines: Vec<Vec<u8>> = text.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
            let k = nth % lines.len();
            let mut out = Vec::with_capacity(text.len());
            for (i, l) in lines.iter().enumerate() {
                let copies = if i == k { 1 + times } else { 1 };
                for _ in 0..copies {
                    out.extend_from_slice(l);
                    out.push(b'\n');
                }
            }
            *text = out;
        }
        Mutation::SwapLines { a, b } => {
            let mut lines: Vec<Vec<u8>> = text.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
            let len = lines.len();
            lines.swap(a % len, b % len);
            *text = lines.join(&b'\n');
        }
        Mutation::Truncate { at } => text.truncate(pos(*at)),
        Mutation::FlipBit { at, bit } => {
            if n > 0 {
                text[at % n] ^= 1 << bit;
            }
        }
    }
}
