//! The generic reader for EXRs with unknown channel naming, driven by `--map attr=channel,…`.
//!
//! Every mapped channel is taken as-is in the crate's view space (+X right, +Y up, looking along −Z), one sample
//! per pixel. Depth is the positive distance along the view axis; a depth channel holding mostly negative values
//! is taken to be view-space z and negated. Coverage: a sample is background when its depth is 0 or its magnitude is at least
//! [`BACKGROUND_DEPTH`] (renderers write 0, 1e10 or +Inf for sky), or, without depth, when its position is
//! exactly zero. Float-coded IDs are rounded; negative or non-finite ones become 0.

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer};
use crate::io::conventions::Conventions;
use crate::io::exr::{RawChannel, RawData, RawImage};
use crate::io::{AttributeSource, LoadOptions, Loaded, SourceFormat};
use glam::{Vec2, Vec3};
use std::path::Path;

pub use crate::io::conventions::BACKGROUND_DEPTH;

/// The `--map` hint appended to errors about unknown naming.
pub const MAP_HINT: &str = "name the channels with --map attr=channel,… (components separated by `;`), e.g. \
                            --map 'depth=Z,normal=N.X;N.Y;N.Z,albedo=C.R;C.G;C.B'";

/// What a `--map` value names: channels of the dump per attribute, and attributes read from other files.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MapSpec {
    /// Attribute → its channels in the dump ([`LoadOptions::map`]).
    pub channels: Vec<(Attribute, Vec<String>)>,
    /// Attribute → file (relative to the dump's directory) and channels, empty for the default
    /// ([`LoadOptions::files`]).
    pub files: Vec<(Attribute, std::path::PathBuf, Vec<String>)>,
}

/// Parses the `--map` grammar, `attr=ch;ch;ch,attr=FILE[:ch;…],…` (components separated by `;`, a value ending in
/// `.exr` or `.png` before an optional `:` names a file), or says what is wrong with it.
pub fn parse_map(spec: &str) -> std::result::Result<MapSpec, String> {
    let mut out = MapSpec::default();
    for item in spec.split(',').filter(|s| !s.trim().is_empty()) {
        let (attr, chans) = item.split_once('=').ok_or_else(|| format!("--map: {item:?} is not attr=channel"))?;
        let a = Attribute::from_name(attr.trim()).ok_or_else(|| {
            format!("--map: unknown attribute {attr:?}; known: {}", Attribute::ALL.map(|a| a.name()).join(", "))
        })?;
        let chans = chans.trim();
        let is_image = |f: &str| {
            let f = f.to_ascii_lowercase();
            f.ends_with(".exr") || f.ends_with(".png")
        };
        let (file, chans) = match chans.split_once(':') {
            Some((f, c)) if is_image(f) => (Some(f), c),
            _ if is_image(chans) => (Some(chans), ""),
            _ => (None, chans),
        };
        let chans: Vec<String> = chans.split(';').map(|c| c.trim().to_string()).filter(|c| !c.is_empty()).collect();
        let wrong = || format!("--map: {} needs {} channel(s), got {}", a.name(), a.components(), chans.len());
        match file {
            Some(f) if chans.is_empty() || chans.len() == a.components() => {
                out.files.push((a, std::path::PathBuf::from(f), chans));
            }
            None if chans.len() == a.components() => out.channels.push((a, chans)),
            _ => return Err(wrong()),
        }
    }
    Ok(out)
}

/// Looks up channel `name`, or says which channels exist.
pub fn channel<'a>(raw: &'a RawImage, path: &Path, name: &str) -> Result<&'a RawChannel> {
    raw.channel(name).ok_or_else(|| Error::MissingChannel {
        path: path.into(),
        name: name.to_string(),
        found: raw.channel_list(),
    })
}

/// A channel's samples as IDs: uint channels as they are, float channels rounded (negative/non-finite → 0).
#[must_use]
pub fn ids(ch: &RawChannel) -> Vec<u32> {
    match &ch.data {
        RawData::U32(v) => v.clone(),
        other => other
            .to_f32_vec()
            .into_iter()
            .map(|f| if f.is_finite() && f > 0.0 { f.round() as u32 } else { 0 })
            .collect(),
    }
}

fn floats(ch: &RawChannel) -> Vec<f32> {
    ch.data.to_f32_vec()
}

/// Reads `raw` with the explicit mapping `opts.map` (see the module docs) under the declared conventions
/// (`opts.conventions` over the defaults: view space, view-z depth, automatic background). Needs depth or position.
pub fn read(raw: &RawImage, path: &Path, camera: Option<&Camera>, opts: &LoadOptions) -> Result<Loaded> {
    let has = |a: Attribute| opts.map.iter().any(|(m, _)| *m == a);
    if !has(Attribute::Depth) && !has(Attribute::Position) {
        let what = if opts.map.is_empty() {
            "depth or position: unknown channel naming (not a gbuf canonical, Blender or Mitsuba file)"
        } else {
            "depth or position: --map names neither"
        };
        return Err(Error::MissingChannel {
            path: path.into(),
            name: format!("{what}; {MAP_HINT}"),
            found: raw.channel_list(),
        });
    }
    let mut gb = GBuffer::new(raw.width, raw.height, 1).map_err(|e| Error::invalid(path, e.to_string()))?;
    let mut sources = Vec::new();
    let conventions = Conventions::default().with(&opts.conventions);
    for (attr, names) in &opts.map {
        if names.len() != attr.components() {
            return Err(Error::Argument(format!(
                "--map: {} needs {} channel(s), got {}",
                attr.name(),
                attr.components(),
                names.len()
            )));
        }
        let chans = names.iter().map(|n| channel(raw, path, n)).collect::<Result<Vec<_>>>()?;
        let file_type = chans.iter().map(|c| c.data.type_name()).collect::<Vec<_>>().join("/");
        let note = Some(format!("mapped with --map ({})", conventions.space.name()));
        set_plane(&mut gb, *attr, &chans);
        sources.push(AttributeSource { attribute: attr.name(), channels: names.clone(), file_type, note });
    }
    let alpha: Option<Vec<f32>> = raw.channel("A").map(|c| c.data.to_f32_vec());
    for (attr, note) in conventions.apply(&mut gb, camera, alpha.as_deref(), path)? {
        if let Some(s) = sources.iter_mut().find(|s| s.attribute == attr) {
            s.note = Some(format!("{}; {note}", s.note.take().unwrap_or_default()));
        }
    }
    Ok(Loaded {
        gbuffer: gb,
        format: SourceFormat::Mapped,
        sources,
        lights: None,
        camera_source: super::CameraSource::Unknown,
        compression: Some((raw.compression.clone(), raw.lossy)),
        sanitized: Vec::new(),
        warnings: Vec::new(),
        reading: Some(super::fileset::Reading { preset: None, conventions, basis: None, ignored: Vec::new() }),
        positions_assumed: false,
    })
}

/// Sets `attr`'s plane of a one-sample G-buffer from its component channels.
pub fn set_plane(gb: &mut GBuffer, attr: Attribute, chans: &[&RawChannel]) {
    let f = |i: usize| floats(chans[i]);
    match attr {
        Attribute::Depth => gb.depth = Some(f(0)),
        Attribute::Specular => gb.specular = Some(f(0)),
        Attribute::SpecularPower => gb.specular_power = Some(f(0)),
        Attribute::Roughness => gb.roughness = Some(f(0)),
        Attribute::Metallic => gb.metallic = Some(f(0)),
        Attribute::MaterialId => gb.material_id = Some(ids(chans[0])),
        Attribute::ObjectId => gb.object_id = Some(ids(chans[0])),
        Attribute::PrimitiveId => gb.primitive_id = Some(ids(chans[0])),
        Attribute::Motion => {
            let (x, y) = (f(0), f(1));
            gb.motion = Some(x.iter().zip(&y).map(|(&a, &b)| Vec2::new(a, b)).collect());
        }
        Attribute::Position | Attribute::Normal | Attribute::Albedo => {
            let (x, y, z) = (f(0), f(1), f(2));
            let v: Vec<Vec3> = (0..x.len()).map(|i| Vec3::new(x[i], y[i], z[i])).collect();
            match attr {
                Attribute::Position => gb.position = Some(v),
                Attribute::Normal => gb.normal = Some(v),
                _ => gb.albedo = Some(v),
            }
        }
    }
}

/// Replaces scalar and ID attributes of a one-sample G-buffer read by a format-specific reader with the channels
/// `opts.map` names for them (vectors need the reader's space conversion and are left to it). Returns the
/// attributes replaced.
pub fn override_scalars(
    loaded: &mut Loaded,
    raw: &RawImage,
    path: &Path,
    opts: &LoadOptions,
) -> Result<Vec<Attribute>> {
    let mut done = Vec::new();
    for (attr, names) in &opts.map {
        if attr.components() != 1 || *attr == Attribute::Depth || loaded.gbuffer.samples != 1 {
            continue;
        }
        let ch = channel(raw, path, &names[0])?;
        if ch.data.len() != loaded.gbuffer.len() {
            return Err(Error::SizeMismatch {
                path: path.into(),
                what: format!(
                    "--map channel {} has {} samples, expected {}",
                    ch.name,
                    ch.data.len(),
                    loaded.gbuffer.len()
                ),
            });
        }
        set_plane(&mut loaded.gbuffer, *attr, &[ch]);
        loaded.sources.retain(|s| s.attribute != attr.name());
        loaded.sources.push(AttributeSource {
            attribute: attr.name(),
            channels: names.clone(),
            file_type: ch.data.type_name().into(),
            note: Some("mapped with --map".into()),
        });
        done.push(*attr);
    }
    if !done.is_empty() {
        loaded.gbuffer.zero_background();
    }
    Ok(done)
}
