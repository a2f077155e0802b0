//! The scene sidecar (JSON): camera and glTF-style lights next to a dump (see docs/FORMAT.md).

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::gbuffer::MaterialParams;
use crate::light::{Light, LightKind};
use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The camera as written in a sidecar: row-major world→view matrix plus glTF perspective parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SidecarCamera {
    /// World → view, row-major (4 rows of 4).
    pub world_to_view: [[f32; 4]; 4],
    /// Vertical field of view, radians (may be left out when `intrinsics` are given).
    #[serde(default)]
    pub yfov: f32,
    /// Width / height (may be left out when `intrinsics` are given).
    #[serde(default)]
    pub aspect: f32,
    /// Near plane.
    pub znear: f32,
    /// Far plane.
    pub zfar: f32,
    /// Principal point as an offset from the image centre in NDC units (+x right, +y up); what gbuf writes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub principal_point: Option<[f32; 2]>,
    /// Pinhole intrinsics in pixels of the image as stored (before folding): `[fx, fy, cx, cy]`, +y down, pixel
    /// (0, 0)'s corner at (0, 0). They set the field of view, aspect and principal point (and override those).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub intrinsics: Option<[f32; 4]>,
}

/// A light as written in a sidecar (KHR_lights_punctual fields, plus `begin` for the linear falloff).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SidecarLight {
    /// "point", "spot", "directional" or "hemisphere" (an environment: `direction` is its up, `color` the sky,
    /// `ground` the lower half; gbuf's extension, glTF has no such light).
    #[serde(rename = "type")]
    pub kind: String,
    /// Position (point and spot).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f32; 3]>,
    /// Direction the light points / travels (spot and directional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<[f32; 3]>,
    /// Linear RGB colour (default white).
    #[serde(default = "white")]
    pub color: [f32; 3],
    /// Intensity (default 1).
    #[serde(default = "one")]
    pub intensity: f32,
    /// Range (absent = unbounded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub range: Option<f32>,
    /// Begin radius of the linear falloff.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub begin: Option<f32>,
    /// Spot inner cone angle, radians (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inner_cone_angle: Option<f32>,
    /// Spot outer cone angle, radians (default π/4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outer_cone_angle: Option<f32>,
    /// Ground colour of a hemisphere light (default black).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground: Option<[f32; 3]>,
}

fn white() -> [f32; 3] {
    [1.0; 3]
}
fn one() -> f32 {
    1.0
}

/// The whole sidecar document.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sidecar {
    /// The camera, if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<SidecarCamera>,
    /// Supersampling factor k: fold k×k pixel blocks into k² samples.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub supersample: Option<u32>,
    /// Lights.
    #[serde(default)]
    pub lights: Vec<SidecarLight>,
    /// "world" (default) or "view".
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lights_space: Option<String>,
    /// The engine's materials: parameters per material ID (material-ID indirection uses them as its table).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub materials: Vec<MaterialParams>,
    /// Sample positions (offsets from the pixel centre in pixels, +y down), for inputs that cannot carry them
    /// (packed render targets: `gbuf pack` writes them here); other dumps keep their own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sample_positions: Option<Vec<[f32; 2]>>,
}

impl SidecarCamera {
    /// From a [`Camera`].
    #[must_use]
    pub fn from_camera(c: &Camera) -> Self {
        SidecarCamera {
            world_to_view: c.world_to_view.transpose().to_cols_array_2d(),
            yfov: c.yfov,
            aspect: c.aspect,
            znear: c.znear,
            zfar: c.zfar,
            principal_point: (c.principal != glam::Vec2::ZERO).then_some([c.principal.x, c.principal.y]),
            intrinsics: None,
        }
    }
    /// To a [`Camera`] (not yet validated). `intrinsics` need the image size: see [`SidecarCamera::to_camera_for`];
    /// here they are ignored.
    #[must_use]
    pub fn to_camera(&self) -> Camera {
        let p = self.principal_point.unwrap_or([0.0; 2]);
        Camera {
            world_to_view: Mat4::from_cols_array_2d(&self.world_to_view).transpose(),
            yfov: self.yfov,
            aspect: self.aspect,
            znear: self.znear,
            zfar: self.zfar,
            principal: glam::Vec2::new(p[0], p[1]),
        }
    }

    /// To a [`Camera`] for an image stored at `width × height` pixels (before folding): `intrinsics`, when given,
    /// set the field of view, aspect and principal point.
    #[must_use]
    pub fn to_camera_for(&self, width: u32, height: u32) -> Camera {
        let mut c = self.to_camera();
        if let Some([fx, fy, cx, cy]) = self.intrinsics {
            let (w, h) = (width as f32, height as f32);
            c.yfov = 2.0 * (0.5 * h / fy).atan();
            c.aspect = (w / fx) / (h / fy);
            c.principal = glam::Vec2::new((cx - 0.5 * w) / (0.5 * w), -(cy - 0.5 * h) / (0.5 * h));
        }
        c
    }
}

/// Most lights a sidecar may hold: 64× the 1024 of the ISPC example and of Lauritzen's demo; the resolve's light
/// table and the f64 reference stay within a few hundred MB at this count.
pub const MAX_LIGHTS: usize = 1 << 16;

/// Largest sidecar file read: room for [`MAX_LIGHTS`] lights (about 200 bytes of JSON each) and a material
/// catalogue, so that parsing stays within a few hundred MB.
pub const MAX_SIDECAR_BYTES: u64 = 64 << 20;

/// The top-level keys of a sidecar (`generator` names the program that wrote it and is not read).
pub const KEYS: [&str; 7] =
    ["camera", "supersample", "lights", "lights_space", "materials", "sample_positions", "generator"];

/// What a JSON found beside a dump is ([`Sidecar::load_found`]).
#[derive(Clone, Debug)]
pub enum Found {
    /// A gbuf sidecar.
    Sidecar(Sidecar),
    /// Some other program's JSON: why it is not taken for a sidecar.
    Other(String),
}

/// `problems` as one message: `2 problems: camera: …; lights_space "x" …`.
fn problem_list(problems: &[String]) -> String {
    match problems {
        [one] => format!("sidecar: {one}"),
        many => format!("sidecar, {} problems: {}", many.len(), many.join("; ")),
    }
}

/// The text of a sidecar file, refused above [`MAX_SIDECAR_BYTES`].
fn read_capped(path: &Path) -> Result<String> {
    crate::base::files::protect_input(path);
    let len = std::fs::metadata(path).map_err(|e| Error::io(path, e))?.len();
    if len > MAX_SIDECAR_BYTES {
        return Err(Error::Parse {
            path: path.into(),
            what: format!(
                "sidecar of {len} bytes, over the {} MiB a sidecar may have ({MAX_LIGHTS} lights take about {} MiB \
                 of JSON)",
                MAX_SIDECAR_BYTES >> 20,
                (MAX_LIGHTS as u64 * 200) >> 20
            ),
        });
    }
    std::fs::read_to_string(path).map_err(|e| Error::io(path, e))
}

impl Sidecar {
    /// Reads and parses a sidecar file.
    pub fn load(path: &Path) -> Result<Sidecar> {
        Sidecar::parse(&read_capped(path)?, path)
    }

    /// Parses sidecar JSON (`path` only names the source in errors). Every problem is reported at once, in one
    /// error.
    pub fn parse(text: &str, path: &Path) -> Result<Sidecar> {
        let value: serde_json::Value = serde_json::from_str(text)
            .map_err(|e| Error::Parse { path: path.into(), what: format!("sidecar JSON: {e}") })?;
        let (s, problems) = Sidecar::from_value(&value);
        if problems.is_empty() {
            Ok(s)
        } else {
            Err(Error::Parse { path: path.into(), what: problem_list(&problems) })
        }
    }

    /// Reads a JSON found beside a dump, which the user did not name: a gbuf sidecar, or a file of some other
    /// program (a renderer's own `<stem>.json`), which is no reason to stop. A JSON is taken for a sidecar when its
    /// top-level keys are all a sidecar's ([`KEYS`]), or when it has some of them and reads as one; a sidecar that
    /// has errors is an error, listing all of them.
    pub fn load_found(path: &Path) -> Result<Found> {
        let text = read_capped(path)?;
        let value: serde_json::Value = match serde_json::from_str(&text) {
            Ok(v) => v,
            Err(e) => return Ok(Found::Other(format!("not JSON: {e}"))),
        };
        let Some(obj) = value.as_object() else {
            return Ok(Found::Other("a JSON document whose top level is not an object".into()));
        };
        let ours = obj.keys().filter(|k| KEYS.contains(&k.as_str()) && *k != "generator").count();
        let theirs: Vec<&str> = obj.keys().map(String::as_str).filter(|k| !KEYS.contains(k)).collect();
        if ours == 0 {
            return Ok(Found::Other(format!(
                "none of its keys is a sidecar's ({})",
                KEYS.iter().filter(|k| **k != "generator").copied().collect::<Vec<_>>().join(", ")
            )));
        }
        let (s, problems) = Sidecar::from_value(&value);
        match (problems.is_empty(), theirs.is_empty()) {
            (true, _) => Ok(Found::Sidecar(s)),
            (false, false) => Ok(Found::Other(format!(
                "keys no sidecar has ({}), and read as a sidecar: {}",
                theirs.join(", "),
                problem_list(&problems)
            ))),
            (false, true) => Err(Error::Parse { path: path.into(), what: problem_list(&problems) }),
        }
    }

    /// The sidecar in `value`, and every problem found in it (a field that does not read is left at its default).
    fn from_value(value: &serde_json::Value) -> (Sidecar, Vec<String>) {
        let mut problems = Vec::new();
        let Some(obj) = value.as_object() else {
            return (Sidecar::default(), vec!["the top level is not a JSON object".into()]);
        };
        fn field<T: serde::de::DeserializeOwned + Default>(
            obj: &serde_json::Map<String, serde_json::Value>,
            key: &str,
            problems: &mut Vec<String>,
        ) -> T {
            match obj.get(key) {
                None => T::default(),
                Some(v) => serde_json::from_value(v.clone()).unwrap_or_else(|e| {
                    problems.push(format!("{key}: {e}"));
                    T::default()
                }),
            }
        }
        overflowing_numbers(value, &mut String::new(), &mut problems);
        let s = Sidecar {
            camera: field(obj, "camera", &mut problems),
            supersample: field(obj, "supersample", &mut problems),
            lights: field(obj, "lights", &mut problems),
            lights_space: field(obj, "lights_space", &mut problems),
            materials: field(obj, "materials", &mut problems),
            sample_positions: field(obj, "sample_positions", &mut problems),
        };
        if let Some(c) = &s.camera {
            let intrinsics_ok =
                c.intrinsics.is_none_or(|v| v.iter().all(|x| x.is_finite()) && v[0] > 0.0 && v[1] > 0.0);
            let probe = if c.intrinsics.is_some() { c.to_camera_for(2, 2) } else { c.to_camera() };
            if !intrinsics_ok || !probe.is_valid() {
                problems.push(
                    "camera: not usable (need finite invertible matrix, 0 < yfov < π and aspect > 0 or intrinsics \
                     fx, fy > 0, 0 < znear < zfar)"
                        .into(),
                );
            }
        }
        if let Some(k) = s.supersample {
            if !(1..=8).contains(&k) {
                problems.push(format!("supersample {k} outside 1..=8"));
            }
        }
        if s.lights.len() > MAX_LIGHTS {
            problems.push(format!("{} lights, more than the {MAX_LIGHTS} a sidecar may hold", s.lights.len()));
        }
        if let Err(what) = MaterialParams::validate_all(&s.materials) {
            problems.push(what);
        }
        if let Some(other) = s.lights_space.as_deref().filter(|l| !matches!(*l, "world" | "view")) {
            problems.push(format!("lights_space {other:?} (expected \"world\" or \"view\")"));
        }
        (s, problems)
    }

    /// The lights in view space. World-space lights need the camera (`camera` overrides the sidecar's own).
    pub fn view_lights(&self, camera: Option<&Camera>, path: &Path) -> Result<Vec<Light>> {
        let view_space = self.lights_space.as_deref() == Some("view");
        let cam = camera.copied().or_else(|| self.camera.as_ref().map(SidecarCamera::to_camera));
        let mut out = Vec::with_capacity(self.lights.len());
        for (i, l) in self.lights.iter().enumerate() {
            let bad = |what: &str| Error::Parse { path: path.into(), what: format!("light {i}: {what}") };
            let pos = Vec3::from(l.position.unwrap_or([0.0; 3]));
            let dir = Vec3::from(l.direction.unwrap_or([0.0, 0.0, -1.0]));
            let (pos, dir) = if view_space {
                (pos, dir.normalize_or_zero())
            } else {
                let c = cam.as_ref().ok_or_else(|| bad("world-space lights need a camera"))?;
                (c.to_view_point(pos), c.to_view_dir(dir))
            };
            let kind = match l.kind.as_str() {
                "point" => LightKind::Point,
                "spot" => LightKind::Spot {
                    direction: dir,
                    inner_cone_angle: l.inner_cone_angle.unwrap_or(0.0),
                    outer_cone_angle: l.outer_cone_angle.unwrap_or(std::f32::consts::FRAC_PI_4),
                },
                "directional" => LightKind::Directional { direction: dir },
                "hemisphere" => {
                    let ground = Vec3::from(l.ground.unwrap_or([0.0; 3]));
                    if !ground.is_finite() || ground.min_element() < 0.0 {
                        return Err(bad("hemisphere ground colour must be finite and ≥ 0"));
                    }
                    if l.direction.is_none() {
                        return Err(bad("a hemisphere light needs \"direction\": its up vector"));
                    }
                    LightKind::Hemisphere { up: dir, ground }
                }
                other => return Err(bad(&format!("unknown type {other:?}"))),
            };
            let directed =
                matches!(kind, LightKind::Spot { .. } | LightKind::Directional { .. } | LightKind::Hemisphere { .. });
            if directed && dir == Vec3::ZERO {
                return Err(bad("direction is zero or not finite"));
            }
            let light = Light {
                kind,
                position: pos,
                color: Vec3::from(l.color),
                intensity: l.intensity,
                range: l.range.unwrap_or(f32::INFINITY),
                begin: l.begin.unwrap_or(0.0),
            };
            if !light.position.is_finite()
                || !light.color.is_finite()
                || !light.intensity.is_finite()
                || light.range.is_nan()
                || light.range <= 0.0
                || !light.begin.is_finite()
            {
                return Err(bad("non-finite or non-positive value"));
            }
            out.push(light);
        }
        Ok(out)
    }
}

/// Every number in `value` too large for an `f32` (it would read as infinity, and then neither light nor serialize
/// back), with its path (`camera.principal_point[0]`): JSON has no infinity, so a sidecar that needs one is wrong.
fn overflowing_numbers(value: &serde_json::Value, at: &mut String, problems: &mut Vec<String>) {
    use serde_json::Value;
    let len = at.len();
    match value {
        Value::Number(n) if n.as_f64().is_some_and(|x| x.abs() > f64::from(f32::MAX)) => {
            problems.push(format!("{at}: {n} is beyond the largest 32-bit float ({:e})", f32::MAX));
        }
        Value::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                at.push_str(&format!("[{i}]"));
                overflowing_numbers(item, at, problems);
                at.truncate(len);
            }
        }
        Value::Object(map) => {
            for (key, item) in map {
                if !at.is_empty() {
                    at.push('.');
                }
                at.push_str(key);
                overflowing_numbers(item, at, problems);
                at.truncate(len);
            }
        }
        _ => {}
    }
}
