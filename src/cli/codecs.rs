//! `gbuf codecs`: angular error and speed of every normal codec (the measuring lives in
//! `gbuf::codec::eval`; this file parses flags and prints).

use anyhow::Context;
use gbuf::codec::eval::{evaluate, evaluation_set, CodecRow, EvalOptions};
use gbuf::codec::NormalScheme;
use std::io::Write;

/// Flags of `gbuf codecs`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Total bits per normal to evaluate, comma-separated (e.g. `16,20,24`); each scheme runs at those of the
    /// list it supports. Default: 8, 10, 12 and 16 bits per component, and the f16 sizes.
    #[arg(long, value_name = "LIST")]
    pub bits: Option<String>,
    /// Schemes to evaluate, comma-separated (e.g. `oct,oct-precise`). Default: all.
    #[arg(long, value_name = "LIST")]
    pub schemes: Option<String>,
    /// Points of the deterministic Fibonacci sphere sweep; as many seeded random vectors are added.
    #[arg(long, value_name = "N", default_value_t = 1 << 20)]
    pub samples: usize,
    /// Skip the exhaustive decode → re-encode check of code spaces ≤ 2^24.
    #[arg(long)]
    pub no_exhaustive: bool,
    /// Normals per timing pass (0: skip timing). Timing goes through the codecs' slice paths
    /// (`encode_slice`/`decode_slice`) on one thread.
    #[arg(long, value_name = "N", default_value_t = 1 << 20)]
    pub timing_samples: usize,
    /// Machine-readable output on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Largest `--samples`: 2^26 lattice points plus as many random vectors is 1.5 GiB of input already.
const MAX_SAMPLES: usize = 1 << 26;

/// Parses `--bits`.
fn parse_bits(list: &str) -> anyhow::Result<Vec<u32>> {
    list.split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse::<u32>().with_context(|| format!("--bits: {s:?} is not a bit count")))
        .collect()
}

/// Parses `--schemes`.
fn parse_schemes(list: &str) -> anyhow::Result<Vec<NormalScheme>> {
    list.split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| {
            NormalScheme::from_name(s.trim()).with_context(|| {
                let valid: Vec<&str> = NormalScheme::ALL.iter().map(|s| s.name()).collect();
                format!("--schemes: unknown scheme {s:?}; valid: {}", valid.join(", "))
            })
        })
        .collect()
}

/// The (scheme, bits) pairs to run.
fn plan(args: &Args) -> anyhow::Result<Vec<(NormalScheme, u32)>> {
    let schemes = match &args.schemes {
        Some(list) => parse_schemes(list)?,
        None => NormalScheme::ALL.to_vec(),
    };
    let bits = args.bits.as_deref().map(parse_bits).transpose()?;
    if let Some(bits) = &bits {
        if bits.is_empty() {
            anyhow::bail!("--bits: empty list");
        }
        for &b in bits {
            if !schemes.iter().any(|s| s.valid_bits().contains(&b)) {
                anyhow::bail!("--bits: no selected scheme supports {b} bits per normal");
            }
        }
    }
    let mut jobs = Vec::new();
    for s in schemes {
        let candidates = match &bits {
            Some(b) => b.iter().copied().filter(|b| s.valid_bits().contains(b)).collect(),
            None => s.sweep_bits(),
        };
        jobs.extend(candidates.into_iter().map(|b| (s, b)));
    }
    Ok(jobs)
}

/// Runs `gbuf codecs`.
pub fn run(args: Args) -> anyhow::Result<()> {
    if args.samples == 0 || args.samples > MAX_SAMPLES {
        anyhow::bail!("--samples must be between 1 and {MAX_SAMPLES}, got {}", args.samples);
    }
    let jobs = plan(&args)?;
    let inputs = evaluation_set(args.samples, args.samples);
    let opts = EvalOptions {
        sweep: args.samples,
        random: args.samples,
        exhaustive: !args.no_exhaustive,
        timing_samples: args.timing_samples.min(inputs.len()),
    };
    let pb = crate::cli::progress_bar(jobs.len() as u64);
    let mut rows = Vec::with_capacity(jobs.len());
    for (scheme, bits) in &jobs {
        let codec = scheme.codec(*bits).context("internal: planned an invalid codec")?;
        pb.set_message(codec.name());
        rows.push(evaluate(codec.as_ref(), scheme.name(), &inputs, &opts));
        pb.inc(1);
    }
    pb.finish_and_clear();
    if args.json {
        return crate::cli::common::print_json(&rows);
    }
    print_table(&rows, inputs.len())
}

fn print_table(rows: &[CodecRow], samples: usize) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(out, "{samples} vectors (Fibonacci sweep + seeded random + stiff); errors in degrees")?;
    writeln!(
        out,
        "enc/dec ns: per normal through the slice path (encode_slice/decode_slice), one thread, {}",
        gbuf::base::isa::Isa::detect().name()
    )?;
    writeln!(
        out,
        "{:<22} {:>4} {:>10} {:>10} {:>10} {:>10} {:>9} {:>9}  exhaustive",
        "codec", "bits", "mean", "max", "max z≥0", "bound", "enc ns", "dec ns"
    )?;
    for r in rows {
        let ex = match &r.exhaustive {
            Some(e) if e.bad_decodes > 0 => format!("{} BAD decodes of {}", e.bad_decodes, e.codes),
            Some(e) if e.reencode_mismatches == 0 => format!("{} codes, stable", e.codes),
            Some(e) => format!("{} codes, {} move ≤ {:.4}°", e.codes, e.reencode_mismatches, e.reencode_max_deg),
            None => "-".to_string(),
        };
        writeln!(
            out,
            "{:<22} {:>4} {:>10.5} {:>10.5} {:>10.5} {:>10.5} {:>9.2} {:>9.2}  {ex}",
            r.codec, r.bits, r.mean_deg, r.max_deg, r.max_hemi_deg, r.bound_deg, r.encode_ns, r.decode_ns
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(bits: Option<&str>, schemes: Option<&str>) -> Args {
        Args {
            bits: bits.map(String::from),
            schemes: schemes.map(String::from),
            samples: 10,
            no_exhaustive: true,
            timing_samples: 0,
            json: true,
        }
    }

    #[test]
    fn plan_filters_bits_per_scheme_and_rejects_nonsense() {
        let p = plan(&args(Some("16,48"), Some("oct,xyz-snorm,xyz-f16"))).unwrap();
        let names: Vec<String> = p.iter().map(|(s, b)| format!("{}-{b}", s.name())).collect();
        assert_eq!(names, ["oct-16", "xyz-snorm-48", "xyz-f16-48"]);
        assert!(plan(&args(Some("17"), None)).unwrap_err().to_string().contains("17 bits"));
        assert!(plan(&args(Some("x"), None)).is_err());
        assert!(plan(&args(None, Some("octa"))).unwrap_err().to_string().contains("oct-precise"));
        let all = plan(&args(None, None)).unwrap();
        assert!(all.len() > 40, "{}", all.len());
    }
}
