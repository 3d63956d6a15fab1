//! `blind-gen --out DIR [--seed N] [--set suite|devices]`: writes each case as DIR/<name>.csv
//! (`t,deflection,torque`) and DIR/answers.json.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

fn usage() -> ExitCode {
    eprintln!("usage: blind-gen --out DIR [--seed N] [--set suite|devices] [--verbose]");
    ExitCode::from(2)
}

fn main() -> ExitCode {
    let mut out: Option<PathBuf> = None;
    let mut seed: u64 = 1;
    let mut set = String::from("suite");
    let mut verbose = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--out" => out = args.next().map(PathBuf::from),
            "--seed" => match args.next().and_then(|s| s.parse().ok()) {
                Some(s) => seed = s,
                None => return usage(),
            },
            "--set" => match args.next() {
                Some(s) if s == "suite" || s == "devices" => set = s,
                _ => return usage(),
            },
            "--verbose" | "-v" => verbose = true,
            "-h" | "--help" => {
                usage();
                return ExitCode::SUCCESS;
            }
            _ => return usage(),
        }
    }
    let Some(out) = out else { return usage() };
    let start = Instant::now();
    let cases = if set == "suite" && verbose {
        // One by one, with each case's generation time.
        jointctl_blind_gen::suite_plan(seed)
            .iter()
            .map(|spec| {
                let t0 = Instant::now();
                let (c, _) = spec.generate().map_err(|e| format!("{}: {e}", spec.name))?;
                eprintln!(
                    "{:<40} {:>8} samples {:>7.3} s",
                    c.name,
                    c.t.len(),
                    t0.elapsed().as_secs_f64()
                );
                Ok(c)
            })
            .collect::<Result<Vec<_>, String>>()
    } else if set == "suite" {
        jointctl_blind_gen::try_suite(seed)
    } else {
        jointctl_blind_gen::try_device_variants(seed)
    };
    let cases = match cases {
        Ok(cases) => cases,
        Err(e) => {
            eprintln!("blind-gen: seed {seed}: cannot generate {e}");
            return ExitCode::FAILURE;
        }
    };
    let gen_s = start.elapsed().as_secs_f64();
    if let Err(e) = jointctl_blind_gen::write_set(&cases, &out) {
        eprintln!("blind-gen: cannot write {}: {e}", out.display());
        return ExitCode::FAILURE;
    }
    let samples: usize = cases.iter().map(|c| c.t.len()).sum();
    eprintln!(
        "blind-gen: {} cases, {} samples, generated in {:.1} s, written to {}",
        cases.len(),
        samples,
        gen_s,
        out.display()
    );
    ExitCode::SUCCESS
}
