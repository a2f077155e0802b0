//! Mitsuba 3 `aov` integrator EXR reader.
//!
//! The `aov` integrator writes one channel group per AOV, named by the user (`aovs: "dd.y:depth,nn:sh_normal"` gives
//! `dd.y.T`, `nn.X`, `nn.Y`, `nn.Z`), so groups are mapped by their channel suffixes and type hints in the name:
//! `.T` is depth, `.I` an index (`prim` in the name → primitive ID, otherwise the shape index → object ID),
//! `.X/.Y/.Z` a normal (`sh_normal` preferred over `geo_normal`) or a position (by name, else by whether the values
//! are unit vectors), `.R/.G/.B` the albedo, `.U/.V` texture coordinates (no G-buffer attribute; ignored). `--map`
//! overrides any of it. The root `R, G, B, A` channels (a nested integrator's image) are ignored.
//!
//! Conversions: everything is in world space (Y-up by convention, but any world works): positions and normals are
//! brought into view space with the camera (sidecar, else fitted to the positions). `depth.T` is the ray distance
//! t, not view z, and Mitsuba 3's perspective sensor starts its rays on the near plane (`ray.o += ray.d · near_t`),
//! so t is measured from there: view depth is −z of the view-space position when positions are present, else
//! `znear + t / |r|` with r the pixel-centre view ray scaled to z = −1 (this needs the sidecar's `znear` to be the
//! sensor's `near_clip`). Background is all zeros → no surface.

use super::blender::{derived, map_covered, mask, normals_to_view, resolve_camera, sidecar_lights, src, Channels};
use super::exr::RawImage;
use super::sidecar::Sidecar;
use super::{LoadOptions, Loaded, SourceFormat};
use crate::error::{Error, Result};
use crate::gbuffer::{Attribute, GBuffer, PlaneSlot};
use glam::{Vec2, Vec3};
use std::path::Path;

/// Share of covered samples whose XYZ values must be unit length (±1%) for an unnamed group to count as a normal.
const UNIT_SHARE: f32 = 0.95;

/// What a channel group holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Depth,
    Position,
    /// A normal; `rank` orders candidates (0 = shading normal by name, 1 = unnamed unit vectors, 2 = geometric).
    Normal(u8),
    /// XYZ with no name hint; decided by the data.
    UnknownXyz,
    Albedo,
    ShapeIndex,
    PrimIndex,
    Uv,
}

/// One AOV: its name (the channel prefix), what it holds and its channel names in component order.
#[derive(Clone, Debug)]
struct Group {
    name: String,
    kind: Kind,
    channels: Vec<String>,
}

fn groups(raw: &RawImage) -> Vec<Group> {
    let mut by_prefix: Vec<(String, Vec<String>)> = Vec::new();
    for c in &raw.channels {
        let Some((prefix, _)) = c.name.rsplit_once('.') else { continue };
        match by_prefix.iter_mut().find(|(p, _)| p == prefix) {
            Some((_, v)) => v.push(c.name.clone()),
            None => by_prefix.push((prefix.to_string(), vec![c.name.clone()])),
        }
    }
    let mut out = Vec::new();
    for (name, chans) in by_prefix {
        let has = |s: &[&str]| -> Option<Vec<String>> {
            let names: Vec<String> = s.iter().map(|c| format!("{name}.{c}")).collect();
            (chans.len() == s.len() && names.iter().all(|n| chans.contains(n))).then_some(names)
        };
        let lower = name.to_ascii_lowercase();
        let (kind, channels) = if let Some(c) = has(&["T"]) {
            (Kind::Depth, c)
        } else if let Some(c) = has(&["I"]) {
            (if lower.contains("prim") { Kind::PrimIndex } else { Kind::ShapeIndex }, c)
        } else if let Some(c) = has(&["X", "Y", "Z"]) {
            let kind = if lower.contains("geo") && lower.contains("normal") {
                Kind::Normal(2)
            } else if lower.contains("normal") || lower == "nn" || lower == "n" {
                Kind::Normal(0)
            } else if lower.contains("pos") || lower == "p" {
                Kind::Position
            } else {
                Kind::UnknownXyz
            };
            (kind, c)
        } else if let Some(c) = has(&["R", "G", "B"]) {
            (Kind::Albedo, c)
        } else if let Some(c) = has(&["U", "V"]) {
            (Kind::Uv, c)
        } else {
            continue;
        };
        out.push(Group { name, kind, channels });
    }
    out
}

/// Does `raw` look like a Mitsuba `aov` EXR: a depth (`.T`) or index (`.I`) group — the channel suffixes only
/// Mitsuba's `aov` integrator writes — and not a canonical or Blender file? XYZ and RGB groups alone (any merge
/// of passes has them) are not enough: such files go to the `--map` reader, which asks for their conventions.
#[must_use]
pub fn matches(raw: &RawImage) -> bool {
    !super::canonical::matches(raw)
        && !super::blender::matches(raw)
        && groups(raw).iter().any(|g| matches!(g.kind, Kind::Depth | Kind::ShapeIndex | Kind::PrimIndex))
}

/// Reads a Mitsuba 3 `aov` EXR into a single-sample G-buffer (folding is the caller's job).
pub fn read(raw: &RawImage, path: &Path, sidecar: Option<&Sidecar>, opts: &LoadOptions) -> Result<Loaded> {
    let ch = Channels::new(raw, path, opts);
    let mut gs = groups(raw);
    // Unnamed XYZ groups: unit vectors are normals, anything else positions.
    for g in &mut gs {
        if g.kind == Kind::UnknownXyz {
            // An unnamed XYZ group we cannot read as floats is not geometry: leave it out.
            let Ok(v) = ch.vec3(&g.channels) else {
                g.kind = Kind::Uv;
                continue;
            };
            let nonzero: Vec<&Vec3> = v.iter().filter(|p| **p != Vec3::ZERO).collect();
            let unit = nonzero.iter().filter(|p| (p.length() - 1.0).abs() < 0.01).count();
            g.kind = if !nonzero.is_empty() && unit as f32 >= UNIT_SHARE * nonzero.len() as f32 {
                Kind::Normal(1)
            } else {
                Kind::Position
            };
        }
    }
    let best = |want: fn(Kind) -> Option<u8>| -> Option<Vec<String>> {
        gs.iter().filter_map(|g| want(g.kind).map(|r| (r, g))).min_by_key(|(r, _)| *r).map(|(_, g)| g.channels.clone())
    };
    let depth_ch = ch.pick(Attribute::Depth, best(|k| (k == Kind::Depth).then_some(0)), 1)?;
    let pos_ch = ch.pick(Attribute::Position, best(|k| (k == Kind::Position).then_some(0)), 3)?;
    let normal_ch = ch.pick(
        Attribute::Normal,
        best(|k| match k {
            Kind::Normal(r) => Some(r),
            _ => None,
        }),
        3,
    )?;
    // Several RGB groups: the one named like an albedo wins, else the first.
    let albedo_found = gs
        .iter()
        .filter(|g| g.kind == Kind::Albedo)
        .min_by_key(|g| !g.name.to_ascii_lowercase().contains("albedo"))
        .map(|g| g.channels.clone());
    let albedo_ch = ch.pick(Attribute::Albedo, albedo_found, 3)?;
    let obj_ch = ch.pick(Attribute::ObjectId, best(|k| (k == Kind::ShapeIndex).then_some(0)), 1)?;
    let prim_ch = ch.pick(Attribute::PrimitiveId, best(|k| (k == Kind::PrimIndex).then_some(0)), 1)?;
    let mut scalar_ch = Vec::new();
    for attr in [Attribute::Specular, Attribute::SpecularPower, Attribute::Roughness, Attribute::Metallic] {
        if let Some(c) = ch.pick(attr, None, 1)? {
            scalar_ch.push((attr, c));
        }
    }

    let t = depth_ch.as_ref().map(|c| ch.floats(&c[0])).transpose()?;
    let pos_world = pos_ch.as_ref().map(|c| ch.vec3(c)).transpose()?;
    let normal_world = normal_ch.as_ref().map(|c| ch.vec3(c)).transpose()?;
    if t.is_none() && pos_world.is_none() && normal_world.is_none() {
        return Err(Error::MissingChannel {
            path: path.into(),
            name: "a depth (<name>.T), position or normal (<name>.X/Y/Z) AOV; map one with --map".into(),
            found: raw.channel_list(),
        });
    }
    let (w, h) = (raw.width, raw.height);
    let mut gb = GBuffer::new(w, h, 1)?;
    let n = gb.len();
    // Background: the aov integrator writes zeros where the ray escaped.
    for i in 0..n {
        gb.coverage[i] = match (&t, &normal_world, &pos_world) {
            (Some(t), _, _) => t[i].is_finite() && t[i] > 0.0,
            (None, Some(nw), _) => nw[i] != Vec3::ZERO,
            (None, None, Some(p)) => p[i] != Vec3::ZERO,
            (None, None, None) => unreachable!("checked above"),
        };
    }
    let cam = resolve_camera(sidecar, pos_world.as_deref(), &gb.coverage, w, h, path)?;
    gb.camera = cam.camera;
    let mut sources = Vec::new();

    if let (Some(p), Some(c)) = (&pos_world, &pos_ch) {
        match &gb.camera {
            Some(camera) => {
                let m = camera.world_to_view;
                gb.position = Some(map_covered(&gb.coverage, p, |v| m.transform_point3(v)));
                sources.push(src("position", c, ch.type_of(&c[0]), Some(&format!("world→view ({})", cam.detail))));
            }
            None => sources.push(src(
                "position",
                c,
                ch.type_of(&c[0]),
                Some(&format!("DROPPED: world-space positions and no camera ({})", cam.detail)),
            )),
        }
    }
    match (&t, &depth_ch, &gb.position, &gb.camera) {
        (_, _, Some(p), _) => {
            gb.depth = Some(mask(&gb.coverage, p.iter().map(|v| -v.z).collect(), 0.0));
            let mut note = "−z of the view-space position".to_string();
            if depth_ch.is_some() {
                note.push_str(" (depth.T is the ray distance; position is exact)");
            }
            sources.push(derived("depth", &note));
        }
        (Some(t), Some(c), None, Some(camera)) => {
            let mut d = vec![0.0; n];
            for (i, di) in d.iter_mut().enumerate() {
                if gb.coverage[i] {
                    let px = Vec2::new((i % w as usize) as f32 + 0.5, (i / w as usize) as f32 + 0.5);
                    *di = camera.znear + t[i] / camera.view_ray(px, w, h).length();
                }
            }
            gb.depth = Some(d);
            let note = "ray distance t from the near plane → view depth znear + t / |pixel-centre ray with z = −1|";
            sources.push(src("depth", c, ch.type_of(&c[0]), Some(note)));
        }
        (Some(t), Some(c), None, None) => {
            gb.depth = Some(mask(&gb.coverage, t.clone(), 0.0));
            let note = format!("RAY DISTANCE t, NOT view depth: no camera to convert it ({})", cam.detail);
            sources.push(src("depth", c, ch.type_of(&c[0]), Some(&note)));
        }
        _ => {}
    }
    if let (Some(nw), Some(c)) = (normal_world, &normal_ch) {
        let (plane, mut note) = normals_to_view(&gb.coverage, &nw, gb.camera.as_ref(), &cam.detail);
        if gs.iter().any(|g| g.kind == Kind::Normal(2)) && !c[0].to_ascii_lowercase().contains("geo") {
            note.push_str("; preferred over geo_normal");
        }
        gb.normal = Some(plane);
        sources.push(src("normal", c, ch.type_of(&c[0]), Some(&note)));
    }
    if let Some(c) = &albedo_ch {
        gb.albedo = Some(mask(&gb.coverage, ch.vec3(c)?, Vec3::ZERO));
        sources.push(src("albedo", c, ch.type_of(&c[0]), None));
    }
    for (attr, c) in [(Attribute::ObjectId, &obj_ch), (Attribute::PrimitiveId, &prim_ch)] {
        if let Some(c) = c {
            let (ids, odd) = ch.ids(&c[0])?;
            let ids = mask(&gb.coverage, ids, 0);
            let mut note =
                if attr == Attribute::ObjectId { "shape index".to_string() } else { "primitive index".into() };
            if odd > 0 {
                note.push_str(&format!("; {odd} non-integral or negative values rounded/clamped"));
            }
            if attr == Attribute::ObjectId {
                gb.object_id = Some(ids);
            } else {
                gb.primitive_id = Some(ids);
            }
            sources.push(src(attr.name(), c, ch.type_of(&c[0]), Some(&note)));
        }
    }
    for (attr, c) in &scalar_ch {
        let plane = mask(&gb.coverage, ch.floats(&c[0])?, 0.0);
        if let PlaneSlot::F32(slot) = gb.slot(*attr) {
            *slot = Some(plane);
        }
        sources.push(src(attr.name(), c, ch.type_of(&c[0]), Some("--map")));
    }
    gb.validate()?;
    let lights = sidecar_lights(sidecar, gb.camera.as_ref(), path)?;
    Ok(Loaded {
        gbuffer: gb,
        format: SourceFormat::Mitsuba,
        sources,
        lights,
        camera_source: cam.source,
        compression: Some((raw.compression.clone(), raw.lossy)),
        sanitized: Vec::new(),
        warnings: Vec::new(),
        reading: None,
        positions_assumed: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::exr::{RawChannel, RawData};

    fn img(names: &[&str]) -> RawImage {
        RawImage {
            width: 1,
            height: 1,
            channels: names.iter().map(|n| RawChannel { name: (*n).into(), data: RawData::F32(vec![0.0]) }).collect(),
            ..Default::default()
        }
    }

    #[test]
    fn groups_are_classified_by_suffix_and_name() {
        let raw = img(&[
            "R",
            "G",
            "B",
            "dd.y.T",
            "nn.X",
            "nn.Y",
            "nn.Z",
            "geo_normal.X",
            "geo_normal.Y",
            "geo_normal.Z",
            "pp.X",
            "pp.Y",
            "pp.Z",
            "my_prims.I",
            "obj.I",
            "alb.R",
            "alb.G",
            "alb.B",
            "uv.U",
            "uv.V",
        ]);
        let g = groups(&raw);
        let kind = |n: &str| g.iter().find(|x| x.name == n).unwrap().kind;
        assert_eq!(kind("dd.y"), Kind::Depth);
        assert_eq!(kind("nn"), Kind::Normal(0));
        assert_eq!(kind("geo_normal"), Kind::Normal(2));
        assert_eq!(kind("pp"), Kind::UnknownXyz);
        assert_eq!(kind("my_prims"), Kind::PrimIndex);
        assert_eq!(kind("obj"), Kind::ShapeIndex);
        assert_eq!(kind("alb"), Kind::Albedo);
        assert_eq!(kind("uv"), Kind::Uv);
        assert!(g.iter().all(|x| !x.name.is_empty()), "root channels are not a group");
        assert!(matches(&raw));
        assert!(!matches(&img(&["R", "G", "B", "A"])));
        assert!(!matches(&img(&["ViewLayer.Depth.Z"])), "Blender");
    }
}
