//! Flags shared by every command that reads a dump, and output helpers.
#![allow(dead_code)] // helpers used by the subcommands as they land

use anyhow::Context;
use gbuf::gbuffer::Attribute;
use gbuf::io::{LoadOptions, Loaded, ReadLimits};
use std::io::Write;
use std::path::PathBuf;

/// How to read the input dump.
#[derive(clap::Args, Debug, Clone)]
pub struct InputArgs {
    /// The dump: canonical/Blender/Mitsuba EXR or ISPC `deferred` .bin.
    pub file: PathBuf,
    /// Scene sidecar (camera + lights). Default: `<file stem>.json` beside the dump, if present.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Fold k×k pixel blocks of a supersampled dump into k² samples per pixel.
    #[arg(long, value_name = "K")]
    pub fold: Option<u32>,
    /// Attribute → channel overrides: `normal=N.X;N.Y;N.Z,depth=Z` (components separated by `;`).
    #[arg(long, value_name = "ATTR=CHANNEL,…")]
    pub map: Option<String>,
    /// Refuse files whose decoded samples would need more than this many MiB.
    #[arg(long, value_name = "MIB", default_value_t = 4096)]
    pub max_memory: u64,
    /// Decode DWAA/DWAB-compressed EXRs (lossy; the decoder is less hardened).
    #[arg(long)]
    pub allow_dwa: bool,
}

impl InputArgs {
    /// Library load options from the flags.
    pub fn options(&self) -> anyhow::Result<LoadOptions> {
        let mut map = Vec::new();
        if let Some(spec) = &self.map {
            for item in spec.split(',').filter(|s| !s.trim().is_empty()) {
                let (attr, chans) =
                    item.split_once('=').with_context(|| format!("--map: {item:?} is not attr=channel"))?;
                let a = Attribute::from_name(attr.trim()).with_context(|| {
                    format!("--map: unknown attribute {attr:?}; known: {}", Attribute::ALL.map(|a| a.name()).join(", "))
                })?;
                let chans: Vec<String> = chans.split(';').map(|c| c.trim().to_string()).collect();
                if chans.len() != a.components() {
                    anyhow::bail!("--map: {} needs {} channel(s), got {}", a.name(), a.components(), chans.len());
                }
                map.push((a, chans));
            }
        }
        Ok(LoadOptions {
            sidecar: self.scene.clone(),
            fold: self.fold,
            map,
            limits: ReadLimits { max_bytes: self.max_memory.saturating_mul(1 << 20), allow_dwa: self.allow_dwa },
        })
    }

    /// Loads the dump.
    pub fn load(&self) -> anyhow::Result<Loaded> {
        let opts = self.options()?;
        Ok(gbuf::io::load(&self.file, &opts)?)
    }
}

/// Prints a value as pretty JSON on stdout.
pub fn print_json<T: serde::Serialize>(value: &T) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    serde_json::to_writer_pretty(&mut out, value)?;
    writeln!(out)?;
    Ok(())
}
