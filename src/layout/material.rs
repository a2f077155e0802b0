//! Material-ID indirection (the Destiny idea): instead of storing specular, specular power, roughness and metallic
//! per sample, store a k-bit index into a table of material parameters.
//!
//! Two keys ([`MaterialKey`]). By the engine's material ID, as Destiny does: one entry per distinct ID over the
//! covered samples (the index is the ID's rank among them), holding the per-ID mean of each parameter; the error
//! is the per-sample variation inside a material (textured roughness, say). When the dump's sidecar declares the
//! engine's materials (`materials`, see docs/FORMAT.md), their stated values replace the means: the table is the
//! engine's, and the error is how far the G-buffer's per-sample values stray from it. By palette, for dumps without IDs:
//! the distinct parameter tuples, as follows.
//!
//! Lossless when the G-buffer has at most 2^k distinct tuples (over covered samples). Otherwise the tuples are
//! clustered deterministically: a weighted median cut in normalized parameter space (each parameter divided by
//! its range over the buffer, weights = sample counts) gives 2^k boxes, refined by a few Lloyd (k-means)
//! iterations; the table holds the weighted cluster means and reports the error per parameter.
//! Non-finite parameter values are treated as 0 (documented; the codecs do the same).

use crate::gbuffer::{Attribute, GBuffer, MaterialParams, PlaneRef};
use crate::layout::spec::MaterialKey;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// The most parameters a table holds (every scalar material attribute).
pub const MAX_PARAMETERS: usize = 4;

/// Lloyd iterations after the median cut. Four take most of the gain on real material sets; more is slow for
/// millions of distinct tuples.
pub const LLOYD_ITERATIONS: usize = 4;

/// Skip the Lloyd refinement when `distinct tuples × table entries` exceeds this (it would take seconds).
pub const LLOYD_WORK_LIMIT: u64 = 2_000_000_000;

type Key = [u32; MAX_PARAMETERS];

/// Samples per parallel work item when counting tuples.
const COUNT_CHUNK: usize = 1 << 16;

/// A multiply-rotate hasher (the FxHash of rustc) for [`Key`]s: a few f32 bit patterns from our own buffers need no
/// protection against adversarial collisions, and SipHash was most of the table's build time.
#[derive(Default)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn write(&mut self, bytes: &[u8]) {
        for c in bytes.chunks(8) {
            let mut b = [0u8; 8];
            b[..c.len()].copy_from_slice(c);
            self.write_u64(u64::from_le_bytes(b));
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

type KeyMap<V> = HashMap<Key, V, BuildHasherDefault<KeyHasher>>;

/// The parameter table a packed G-buffer carries, with how well it represents the input.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaterialTable {
    /// Parameter names, in table column order (those of the layout's list that the G-buffer has).
    pub parameters: Vec<String>,
    /// Index bits.
    pub bits: u32,
    /// One row per index.
    pub entries: Vec<Vec<f32>>,
    /// Distinct parameter tuples over covered samples.
    pub distinct_tuples: usize,
    /// True when every tuple has its own entry (so the table reproduces the input exactly).
    pub lossless: bool,
    /// Per parameter: the largest |table value − input| over covered samples.
    pub max_abs_error: Vec<f32>,
    /// Per parameter: the mean |table value − input| over covered samples.
    pub mean_abs_error: Vec<f32>,
    /// What indexed the table: `material-id` or `palette`.
    #[serde(default = "palette_name")]
    pub key: String,
    /// With the `material-id` key: the engine's material ID of each entry.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ids: Vec<u32>,
    /// Table values (entry × parameter) taken from the sidecar's `materials` rather than the per-ID mean.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub from_sidecar: usize,
    /// Why the table is not keyed as asked (e.g. more material IDs than entries), if so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

#[allow(clippy::trivially_copy_pass_by_ref)] // serde's skip_serializing_if passes a reference
fn is_zero(n: &usize) -> bool {
    *n == 0
}

fn palette_name() -> String {
    "palette".into()
}

fn clean(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// The parameter planes of `gb` among `wanted`, in order.
pub(crate) fn parameter_planes<'a>(gb: &'a GBuffer, wanted: &[Attribute]) -> Vec<(Attribute, &'a [f32])> {
    wanted
        .iter()
        .filter_map(|a| match gb.plane(*a) {
            Some(PlaneRef::F32(p)) => Some((*a, p)),
            _ => None,
        })
        .collect()
}

impl MaterialTable {
    /// Builds the table keyed as `key` asks (see [`MaterialKey`]) and returns it with the per-sample index plane
    /// (0 at background samples).
    #[must_use]
    pub fn build_keyed(gb: &GBuffer, wanted: &[Attribute], bits: u32, key: MaterialKey) -> (MaterialTable, Vec<u32>) {
        if key == MaterialKey::Palette {
            return Self::build(gb, wanted, bits);
        }
        let Some(ids) = gb.material_id.as_deref() else {
            let (mut t, i) = Self::build(gb, wanted, bits);
            if key == MaterialKey::MaterialId {
                t.note = Some("the dump has no material IDs: keyed by a palette of the parameter tuples".into());
            }
            return (t, i);
        };
        // The distinct IDs: a set per chunk in parallel, merged, then sorted (the rank is the ID's order).
        // The distinct covered IDs. Small IDs (the usual case) go into a bitmap per block, merged; others into a
        // hash set per block, inserting an ID only when it changes (a surface covers neighbouring samples).
        let covered_ids = || ids.par_chunks(COUNT_CHUNK).zip(gb.coverage.par_chunks(COUNT_CHUNK));
        let max_id = covered_ids()
            .map(|(ids, cov)| ids.iter().zip(cov).filter(|(_, &c)| c).map(|(&id, _)| id).max().unwrap_or(0))
            .max()
            .unwrap_or(0);
        let mut distinct: Vec<u32> = if max_id < 1 << 20 {
            let words = max_id as usize / 64 + 1;
            let bits = covered_ids()
                .map(|(ids, cov)| {
                    let mut b = vec![0u64; words];
                    for (&id, _) in ids.iter().zip(cov).filter(|(_, &c)| c) {
                        b[id as usize / 64] |= 1 << (id % 64);
                    }
                    b
                })
                .reduce(
                    || vec![0u64; words],
                    |mut a, b| {
                        a.iter_mut().zip(&b).for_each(|(x, y)| *x |= y);
                        a
                    },
                );
            (0..=max_id).filter(|&id| bits[id as usize / 64] >> (id % 64) & 1 == 1).collect()
        } else {
            covered_ids()
                .map(|(ids, cov)| {
                    let mut set = std::collections::HashSet::<u32>::new();
                    let mut last = None;
                    for (&id, _) in ids.iter().zip(cov).filter(|(_, &c)| c) {
                        if last != Some(id) {
                            set.insert(id);
                            last = Some(id);
                        }
                    }
                    set
                })
                .reduce(std::collections::HashSet::new, |mut a, b| {
                    a.extend(b);
                    a
                })
                .into_iter()
                .collect()
        };
        distinct.sort_unstable();
        let capacity = 1usize << bits;
        if distinct.len() > capacity {
            let (mut t, i) = Self::build(gb, wanted, bits);
            t.note = Some(format!(
                "{} material IDs do not fit {bits} index bits ({capacity} entries): keyed by a palette instead",
                distinct.len()
            ));
            return (t, i);
        }
        let planes = parameter_planes(gb, wanted);
        let np = planes.len();
        // An ID's rank: a dense table when the IDs are small numbers (the usual case), else a binary search.
        let dense: Option<Vec<u32>> = distinct.last().filter(|&&m| m < 1 << 20).map(|&m| {
            let mut t = vec![0u32; m as usize + 1];
            for (r, &id) in distinct.iter().enumerate() {
                t[id as usize] = r as u32;
            }
            t
        });
        let rank_of = |id: u32| -> u32 {
            match &dense {
                Some(t) => t[id as usize],
                None => distinct.binary_search(&id).map_or(0, |r| r as u32),
            }
        };
        let mut index = vec![0u32; gb.len()];
        index
            .par_chunks_mut(COUNT_CHUNK)
            .zip(ids.par_chunks(COUNT_CHUNK))
            .zip(gb.coverage.par_chunks(COUNT_CHUNK))
            .for_each(|((out, ids), cov)| {
                // The rank of the previous ID is reused while the ID repeats (one hash lookup per run).
                let mut last: Option<(u32, u32)> = None;
                for ((o, &id), &c) in out.iter_mut().zip(ids).zip(cov) {
                    if c {
                        let r = match last {
                            Some((l, r)) if l == id => r,
                            _ => rank_of(id),
                        };
                        last = Some((id, r));
                        *o = r;
                    }
                }
            });
        // Per-ID means, summed in f64 in sample order (deterministic).
        let mut sums = vec![vec![0f64; np]; distinct.len().max(1)];
        let mut counts = vec![0u64; distinct.len().max(1)];
        for i in (0..gb.len()).filter(|&i| gb.coverage[i]) {
            let e = index[i] as usize;
            counts[e] += 1;
            for (p, (_, plane)) in planes.iter().enumerate() {
                sums[e][p] += f64::from(clean(plane[i]));
            }
        }
        // The engine's own values where the sidecar declares them, else the per-ID mean.
        let catalogue: HashMap<u32, &MaterialParams> = gb.materials.iter().map(|m| (m.id, m)).collect();
        let mut from_sidecar = 0;
        let mut undeclared = 0;
        let entries: Vec<Vec<f32>> = sums
            .iter()
            .zip(&counts)
            .enumerate()
            .map(|(e, (s, &c))| {
                let declared = distinct.get(e).and_then(|id| catalogue.get(id));
                let row: Vec<f32> = s
                    .iter()
                    .zip(&planes)
                    .map(|(v, (attr, _))| match declared.and_then(|m| m.get(*attr)) {
                        Some(d) => {
                            from_sidecar += 1;
                            d
                        }
                        None => (v / c.max(1) as f64) as f32,
                    })
                    .collect();
                if !catalogue.is_empty() && declared.is_none() && e < distinct.len() {
                    undeclared += 1;
                }
                row
            })
            .collect();
        let note = (undeclared > 0).then(|| {
            format!(
                "{undeclared} of {} material IDs are not in the sidecar's materials: their entries are per-ID means",
                distinct.len()
            )
        });
        let (max_abs, mean_abs) = table_errors(&planes, &entries, &index, &gb.coverage);
        let lossless = max_abs.iter().all(|&e| e == 0.0);
        let table = MaterialTable {
            parameters: planes.iter().map(|(a, _)| a.name().to_string()).collect(),
            bits,
            entries,
            distinct_tuples: count_tuples(gb, &planes),
            lossless,
            max_abs_error: max_abs,
            mean_abs_error: mean_abs,
            key: MaterialKey::MaterialId.name().into(),
            ids: distinct,
            from_sidecar,
            note,
        };
        (table, index)
    }

    /// Builds a palette table for `gb` (the distinct parameter tuples, clustered when there are more than
    /// `2^bits`) and returns it with the per-sample index plane (0 at background samples).
    #[must_use]
    pub fn build(gb: &GBuffer, wanted: &[Attribute], bits: u32) -> (MaterialTable, Vec<u32>) {
        let planes = parameter_planes(gb, wanted);
        debug_assert!(planes.len() <= MAX_PARAMETERS);
        let key_at = |i: usize| key_of(&planes, i);
        let np = planes.len();
        let values = |k: &Key| -> [f32; MAX_PARAMETERS] { std::array::from_fn(|p| f32::from_bits(k[p])) };
        let capacity = 1usize << bits;
        let distinct = count_tuples(gb, &planes);
        let (entries, index): (Vec<Vec<f32>>, Vec<u32>) = if distinct <= GRID_ABOVE {
            // Counts per chunk in parallel, merged (integer counts: the result does not depend on the split).
            let counts = (0..gb.len())
                .into_par_iter()
                .with_min_len(COUNT_CHUNK)
                .fold(KeyMap::<u64>::default, |mut m, i| {
                    if gb.coverage[i] {
                        *m.entry(key_at(i)).or_insert(0) += 1;
                    }
                    m
                })
                .reduce(KeyMap::<u64>::default, |mut a, b| {
                    for (k, c) in b {
                        *a.entry(k).or_insert(0) += c;
                    }
                    a
                });
            let mut keys: Vec<(Key, u64)> = counts.into_iter().collect();
            keys.sort_unstable_by_key(|(k, _)| *k);
            let (entries, assign): (Vec<Vec<f32>>, Vec<u32>) = if keys.len() <= capacity {
                (keys.iter().map(|(k, _)| values(k)[..np].to_vec()).collect(), (0..keys.len() as u32).collect())
            } else {
                let pts: Vec<[f32; MAX_PARAMETERS]> = keys.iter().map(|(k, _)| values(k)).collect();
                let weights: Vec<u64> = keys.iter().map(|(_, c)| *c).collect();
                cluster(&pts, &weights, np, capacity)
            };
            let lookup: KeyMap<u32> = keys.iter().map(|(k, _)| *k).zip(assign).collect();
            let index =
                (0..gb.len()).into_par_iter().map(|i| if gb.coverage[i] { lookup[&key_at(i)] } else { 0 }).collect();
            (entries, index)
        } else {
            // Too many tuples to cluster one by one: each falls into a cell of a grid over the parameters' ranges
            // (at most 65,536 cells; 16 levels per parameter with four), and the cells, each at the weighted mean of
            // its samples (summed in sample order: deterministic), are clustered instead. Every sample of a cell gets
            // the cell's entry.
            let covered = || (0..gb.len()).into_par_iter().filter(|&i| gb.coverage[i]).map(|i| values(&key_at(i)));
            let (lo, hi) = covered()
                .fold(
                    || ([f32::MAX; MAX_PARAMETERS], [f32::MIN; MAX_PARAMETERS]),
                    |(lo, hi), v| (std::array::from_fn(|p| lo[p].min(v[p])), std::array::from_fn(|p| hi[p].max(v[p]))),
                )
                .reduce(
                    || ([f32::MAX; MAX_PARAMETERS], [f32::MIN; MAX_PARAMETERS]),
                    |a, b| (std::array::from_fn(|p| a.0[p].min(b.0[p])), std::array::from_fn(|p| a.1[p].max(b.1[p]))),
                );
            let grid = Grid::new(lo, hi, np);
            let mut cell_sum = vec![([0f64; MAX_PARAMETERS], 0u64); grid.cells()];
            for i in (0..gb.len()).filter(|&i| gb.coverage[i]) {
                let v = values(&key_at(i));
                let (sum, w) = &mut cell_sum[grid.cell(&v)];
                for p in 0..np {
                    sum[p] += f64::from(v[p]);
                }
                *w += 1;
            }
            let mut point_of_cell = vec![u32::MAX; grid.cells()];
            let (mut pts, mut weights) = (Vec::new(), Vec::new());
            for (cell, (sum, w)) in cell_sum.iter().enumerate() {
                if *w > 0 {
                    point_of_cell[cell] = pts.len() as u32;
                    pts.push(std::array::from_fn(|p| (sum[p] / *w as f64) as f32));
                    weights.push(*w);
                }
            }
            let (centroids, assign) = cluster(&pts, &weights, np, capacity);
            let index =
                (0..gb.len())
                    .into_par_iter()
                    .map(|i| {
                        if gb.coverage[i] {
                            assign[point_of_cell[grid.cell(&values(&key_at(i)))] as usize]
                        } else {
                            0
                        }
                    })
                    .collect();
            (centroids, index)
        };
        let (max_abs, mean_abs) = table_errors(&planes, &entries, &index, &gb.coverage);
        let table = MaterialTable {
            parameters: planes.iter().map(|(a, _)| a.name().to_string()).collect(),
            bits,
            lossless: distinct <= capacity,
            distinct_tuples: distinct,
            entries: if entries.is_empty() { vec![vec![0.0; np]] } else { entries },
            max_abs_error: max_abs,
            mean_abs_error: mean_abs,
            key: palette_name(),
            ids: Vec::new(),
            from_sidecar: 0,
            note: None,
        };
        (table, index)
    }

    /// The table's parameters as attributes.
    #[must_use]
    pub fn attributes(&self) -> Vec<Attribute> {
        self.parameters.iter().filter_map(|p| Attribute::from_name(p)).collect()
    }

    /// Every problem of a table read from a file against the layout's indirection `ind` that indexes it, or none:
    /// each parameter one of the layout's table parameters, none twice; every row as long as the parameter list
    /// and finite; no more entries than the index bits address; as many IDs as entries, when IDs are given. A
    /// table that passes cannot put a value into another attribute's plane or index past a row.
    #[must_use]
    pub fn problems(&self, ind: &super::Indirection) -> Vec<String> {
        let mut out = Vec::new();
        let allowed: Vec<&str> = ind.parameters.iter().map(|a| a.name()).collect();
        for (i, p) in self.parameters.iter().enumerate() {
            if !allowed.contains(&p.as_str()) {
                out.push(format!(
                    "parameters[{i}] = {p:?} is not one of the layout's table parameters ({})",
                    allowed.join(", ")
                ));
            } else if self.parameters[..i].contains(p) {
                out.push(format!("parameters[{i}] = {p:?} is listed twice"));
            }
        }
        let width = self.parameters.len();
        let short: Vec<usize> = (0..self.entries.len()).filter(|&e| self.entries[e].len() != width).collect();
        if let Some(&first) = short.first() {
            out.push(format!(
                "{} of {} rows do not hold one value per parameter ({width}): the first is entries[{first}] with {}",
                short.len(),
                self.entries.len(),
                self.entries[first].len()
            ));
        }
        if let Some(e) = self.entries.iter().position(|row| row.iter().any(|v| !v.is_finite())) {
            out.push(format!("entries[{e}] holds a value that is not a finite number"));
        }
        let most = 1u64 << ind.bits.min(63);
        if self.entries.len() as u64 > most {
            out.push(format!(
                "{} entries, more than the {most} the layout's {}-bit material index addresses",
                self.entries.len(),
                ind.bits
            ));
        }
        if !self.ids.is_empty() && self.ids.len() != self.entries.len() {
            out.push(format!("{} ids for {} entries", self.ids.len(), self.entries.len()));
        }
        out
    }
}

/// Per parameter: the largest and the mean |table value − input| over covered samples.
fn table_errors(
    planes: &[(Attribute, &[f32])],
    entries: &[Vec<f32>],
    index: &[u32],
    coverage: &[bool],
) -> (Vec<f32>, Vec<f32>) {
    let np = planes.len();
    // Per fixed chunk in parallel, combined in chunk order: the sums do not depend on the thread count.
    let partial: Vec<(Vec<f32>, Vec<f64>, u64)> = (0..index.len().div_ceil(COUNT_CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut max_abs, mut sum_abs, mut covered) = (vec![0f32; np], vec![0f64; np], 0u64);
            for i in (c * COUNT_CHUNK..((c + 1) * COUNT_CHUNK).min(index.len())).filter(|&i| coverage[i]) {
                covered += 1;
                for (p, (_, plane)) in planes.iter().enumerate() {
                    let e = (entries[index[i] as usize][p] - clean(plane[i])).abs();
                    max_abs[p] = max_abs[p].max(e);
                    sum_abs[p] += f64::from(e);
                }
            }
            (max_abs, sum_abs, covered)
        })
        .collect();
    let (mut max_abs, mut sum_abs, mut covered) = (vec![0f32; np], vec![0f64; np], 0u64);
    for (m, s, c) in partial {
        for p in 0..np {
            max_abs[p] = max_abs[p].max(m[p]);
            sum_abs[p] += s[p];
        }
        covered += c;
    }
    (max_abs, sum_abs.iter().map(|s| (s / covered.max(1) as f64) as f32).collect())
}

/// The parameter tuple of sample `i` as bit patterns (non-finite values as 0): the key tables are built on.
#[inline(always)]
fn key_of(planes: &[(Attribute, &[f32])], i: usize) -> Key {
    let mut k = [0u32; MAX_PARAMETERS];
    for (p, (_, plane)) in planes.iter().enumerate() {
        k[p] = clean(plane[i]).to_bits();
    }
    k
}

/// Distinct parameter tuples over covered samples, counted exactly without one map of every tuple: the keys are
/// scattered into 256 partitions by hash and each partition's distinct keys are counted on its own, in parallel.
/// What is scattered: each chunk's own distinct keys when every chunk has at most 4,096 (a buffer of few
/// materials: a few keys per chunk, however many samples), else every covered sample's key (textured parameters,
/// where a chunk's set would be as large as its samples and cost more than it saves).
fn count_tuples(gb: &GBuffer, planes: &[(Attribute, &[f32])]) -> usize {
    const PARTITIONS: usize = 256;
    const CHUNK_SET_CAP: usize = 1 << 12;
    let key_at = |i: usize| key_of(planes, i);
    let part = |k: &Key| {
        let mut h = KeyHasher::default();
        for &v in k {
            h.write_u64(u64::from(v));
        }
        (h.finish() >> 56) as usize
    };
    let sets: Vec<Option<KeyMap<()>>> = (0..gb.len())
        .into_par_iter()
        .with_min_len(COUNT_CHUNK)
        .fold(
            || Some(KeyMap::<()>::default()),
            |acc, i| match acc {
                Some(mut set) if gb.coverage[i] => {
                    set.insert(key_at(i), ());
                    (set.len() <= CHUNK_SET_CAP).then_some(set)
                }
                other => other,
            },
        )
        .collect();
    let parts: Vec<Vec<Vec<Key>>> = if sets.iter().all(Option::is_some) {
        sets.into_par_iter()
            .flatten()
            .map(|set| {
                let mut parts = vec![Vec::new(); PARTITIONS];
                for (k, ()) in set {
                    parts[part(&k)].push(k);
                }
                parts
            })
            .collect()
    } else {
        (0..gb.len())
            .into_par_iter()
            .with_min_len(COUNT_CHUNK)
            .fold(
                || vec![Vec::new(); PARTITIONS],
                |mut parts: Vec<Vec<Key>>, i| {
                    if gb.coverage[i] {
                        let k = key_at(i);
                        parts[part(&k)].push(k);
                    }
                    parts
                },
            )
            .collect()
    };
    (0..PARTITIONS)
        .into_par_iter()
        .map(|p| {
            let mut set: KeyMap<()> = KeyMap::default();
            for chunk in &parts {
                for k in &chunk[p] {
                    set.insert(*k, ());
                }
            }
            set.len()
        })
        .sum()
}

/// Distinct tuples above which the palette clusters cells of a grid over the parameters instead of the tuples.
pub const GRID_ABOVE: usize = 1 << 16;

/// A uniform grid over the parameters' ranges with at most 65,536 cells.
struct Grid {
    np: usize,
    levels: u32,
    lo: [f32; MAX_PARAMETERS],
    scale: [f32; MAX_PARAMETERS],
}

impl Grid {
    /// Levels per parameter: 65,536 for one, 256 for two, 40 for three, 16 for four.
    const LEVELS: [u32; MAX_PARAMETERS + 1] = [1, 1 << 16, 256, 40, 12];

    fn new(lo: [f32; MAX_PARAMETERS], hi: [f32; MAX_PARAMETERS], np: usize) -> Grid {
        let levels = Self::LEVELS[np];
        let scale = std::array::from_fn(|p| {
            let range = f64::from(hi[p]) - f64::from(lo[p]);
            if p < np && range > 0.0 && range.is_finite() {
                (f64::from(levels) / range) as f32
            } else {
                0.0
            }
        });
        Grid { np, levels, lo, scale }
    }

    fn cells(&self) -> usize {
        (self.levels as usize).pow(self.np as u32)
    }

    /// The cell of a tuple inside the ranges (the top of each range joins the last level).
    fn cell(&self, v: &[f32; MAX_PARAMETERS]) -> usize {
        v.iter().zip(&self.lo).zip(&self.scale).take(self.np).fold(0usize, |cell, ((&x, &lo), &scale)| {
            let q = (((x - lo) * scale) as u32).min(self.levels - 1);
            cell * self.levels as usize + q as usize
        })
    }
}

/// Weighted median cut into at most `k` boxes, then Lloyd refinement, of `pts` (their first `np` values, each
/// divided by its range over the points for the distances). Returns the centroids (weighted means of their
/// points) and, per point, its centroid index. Deterministic: no randomness, ties broken by index, and the result
/// does not depend on the thread count.
fn cluster(pts: &[[f32; MAX_PARAMETERS]], weights: &[u64], np: usize, k: usize) -> (Vec<Vec<f32>>, Vec<u32>) {
    let mut inv = [0f32; MAX_PARAMETERS];
    for (p, inv) in inv.iter_mut().enumerate().take(np) {
        let (lo, hi) = pts.iter().fold((f32::MAX, f32::MIN), |(lo, hi), v| (lo.min(v[p]), hi.max(v[p])));
        *inv = if hi > lo { 1.0 / (hi - lo) } else { 1.0 };
    }
    // A box: its points, and the weight × normalised spread of its widest parameter (which it is split along).
    struct Box {
        members: Vec<usize>,
        score: f32,
        dim: usize,
    }
    let make = |members: Vec<usize>| -> Box {
        let (mut spread, mut dim) = (-1.0f32, 0);
        for p in 0..np {
            let (lo, hi) =
                members.iter().fold((f32::MAX, f32::MIN), |(lo, hi), &i| (lo.min(pts[i][p]), hi.max(pts[i][p])));
            let s = (hi - lo) * inv[p];
            if s > spread {
                (spread, dim) = (s, p);
            }
        }
        let w: u64 = members.iter().map(|&j| weights[j]).sum();
        let score = if members.len() > 1 { spread * w as f32 } else { -1.0 };
        Box { members, score, dim }
    };
    let mut boxes = vec![make((0..pts.len()).collect())];
    while boxes.len() < k {
        // Split the box with the largest weight × spread (the first on ties).
        let (bi, score) =
            boxes.iter().enumerate().fold(
                (usize::MAX, -1.0f32),
                |best, (i, b)| {
                    if b.score > best.1 {
                        (i, b.score)
                    } else {
                        best
                    }
                },
            );
        if bi == usize::MAX || score <= 0.0 {
            break;
        }
        let Box { mut members, dim, .. } = std::mem::replace(&mut boxes[bi], make(Vec::new()));
        members.sort_by(|&x, &y| pts[x][dim].total_cmp(&pts[y][dim]).then(x.cmp(&y)));
        let total: u64 = members.iter().map(|&j| weights[j]).sum();
        let mut acc = 0;
        let mut cut = 1;
        for (n, &j) in members.iter().enumerate() {
            acc += weights[j];
            if 2 * acc >= total {
                cut = (n + 1).clamp(1, members.len() - 1);
                break;
            }
        }
        let right = members.split_off(cut);
        boxes[bi] = make(members);
        boxes.push(make(right));
    }
    let mut assign = vec![0u32; pts.len()];
    for (c, b) in boxes.iter().enumerate() {
        for &j in &b.members {
            assign[j] = c as u32;
        }
    }
    // Weighted means of each centroid's points, summed in f64 in point order (deterministic).
    let means = |assign: &[u32], n: usize| -> Vec<[f32; MAX_PARAMETERS]> {
        let mut sums = vec![([0f64; MAX_PARAMETERS], 0f64); n];
        for (j, &c) in assign.iter().enumerate() {
            let (s, w) = &mut sums[c as usize];
            for p in 0..np {
                s[p] += f64::from(pts[j][p]) * weights[j] as f64;
            }
            *w += weights[j] as f64;
        }
        sums.iter().map(|(s, w)| std::array::from_fn(|p| if *w > 0.0 { (s[p] / w) as f32 } else { f32::NAN })).collect()
    };
    let mut centroids = means(&assign, boxes.len());
    if (pts.len() as u64).saturating_mul(centroids.len() as u64) <= LLOYD_WORK_LIMIT {
        for _ in 0..LLOYD_ITERATIONS {
            // Centroids by parameter (structure of arrays) and divided by the ranges, so the distances to all of
            // them vectorise; an emptied centroid (NaN) is never nearest.
            let soa: Vec<Vec<f32>> = (0..np)
                .map(|p| centroids.iter().map(|c| if c[p].is_nan() { f32::INFINITY } else { c[p] * inv[p] }).collect())
                .collect();
            assign = pts
                .par_iter()
                .map_init(
                    || vec![0f32; centroids.len()],
                    |d, v| {
                        d.fill(0.0);
                        for (p, cs) in soa.iter().enumerate() {
                            let x = v[p] * inv[p];
                            for (dc, &c) in d.iter_mut().zip(cs) {
                                let t = x - c;
                                *dc += t * t;
                            }
                        }
                        let mut best = (f32::MAX, 0u32);
                        for (c, &dc) in d.iter().enumerate() {
                            if dc < best.0 {
                                best = (dc, c as u32);
                            }
                        }
                        best.1
                    },
                )
                .collect();
            let next = means(&assign, centroids.len());
            for (c, n) in centroids.iter_mut().zip(next) {
                if !n[0].is_nan() || np == 0 {
                    *c = n;
                }
            }
        }
    }
    (centroids.iter().map(|c| c[..np].to_vec()).collect(), assign)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn buffer(values: &[(f32, f32)]) -> GBuffer {
        let mut gb = GBuffer::new(values.len() as u32, 1, 1).unwrap();
        gb.coverage = vec![true; values.len()];
        gb.roughness = Some(values.iter().map(|v| v.0).collect());
        gb.metallic = Some(values.iter().map(|v| v.1).collect());
        gb
    }

    #[test]
    fn few_tuples_are_lossless() {
        let gb = buffer(&[(0.1, 0.0), (0.5, 1.0), (0.1, 0.0), (0.9, 0.5)]);
        let (t, idx) = MaterialTable::build(&gb, &[Attribute::Specular, Attribute::Roughness, Attribute::Metallic], 2);
        assert_eq!(t.parameters, ["roughness", "metallic"]);
        assert!(t.lossless);
        assert_eq!(t.distinct_tuples, 3);
        assert_eq!(t.max_abs_error, [0.0, 0.0]);
        assert_eq!(idx[0], idx[2]);
        assert_eq!(t.entries[idx[3] as usize], [0.9, 0.5]);
    }

    #[test]
    fn too_many_tuples_cluster_and_report_the_error() {
        let vals: Vec<(f32, f32)> = (0..64).map(|i| (i as f32 / 63.0, (i % 2) as f32)).collect();
        let gb = buffer(&vals);
        let (t, idx) = MaterialTable::build(&gb, &[Attribute::Roughness, Attribute::Metallic], 3);
        assert!(!t.lossless);
        assert_eq!(t.entries.len(), 8);
        assert!(t.max_abs_error[0] > 0.0, "{:?}", t.max_abs_error);
        // 8 clusters over a 1-D ramp of 64 (split by metallic): error bounded by a box's width.
        assert!(t.max_abs_error[0] < 0.3, "{:?}", t.max_abs_error);
        let worst = (0..64).map(|i| (t.entries[idx[i] as usize][0] - vals[i].0).abs()).fold(0.0, f32::max);
        assert_eq!(worst, t.max_abs_error[0]);
        // Deterministic.
        assert_eq!(MaterialTable::build(&gb, &[Attribute::Roughness, Attribute::Metallic], 3).0, t);
    }

    /// More distinct tuples than `GRID_ABOVE` (every sample differs by noise) around 100 materials: the grid path
    /// still finds every material (largest error near the noise), and its result does not depend on the threads.
    #[test]
    fn many_noisy_tuples_take_the_grid_path_and_find_the_materials() {
        use crate::base::rng::SplitMix64;
        let mut rng = SplitMix64::new(3);
        let materials: Vec<[f32; 3]> = (0..100).map(|_| [rng.next_f32(), rng.next_f32(), rng.next_f32()]).collect();
        let n = 90_000;
        let mut gb = GBuffer::new(300, 300, 1).unwrap();
        gb.coverage = vec![true; n];
        let mut planes = [Vec::new(), Vec::new(), Vec::new()];
        for _ in 0..n {
            let m = materials[(rng.next_u64() % 100) as usize];
            for (plane, v) in planes.iter_mut().zip(m) {
                plane.push(v + rng.range_f32(-1e-3, 1e-3));
            }
        }
        let [r, m, sp] = planes;
        (gb.roughness, gb.metallic, gb.specular) = (Some(r), Some(m), Some(sp));
        let attrs = [Attribute::Specular, Attribute::Roughness, Attribute::Metallic];
        let build = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| MaterialTable::build(&gb, &attrs, 8))
        };
        let (t, idx) = build(1);
        let exact: std::collections::HashSet<[u32; 3]> = (0..n)
            .map(|i| {
                let p = |v: &Option<Vec<f32>>| v.as_ref().unwrap()[i].to_bits();
                [p(&gb.specular), p(&gb.roughness), p(&gb.metallic)]
            })
            .collect();
        assert_eq!(t.distinct_tuples, exact.len(), "the distinct count is exact");
        assert!(t.distinct_tuples > GRID_ABOVE, "{}", t.distinct_tuples);
        assert!(!t.lossless && t.entries.len() <= 256);
        assert!(t.max_abs_error.iter().all(|&e| e < 0.01), "{:?}", t.max_abs_error);
        assert_eq!(build(2), (t, idx), "one thread and two give the same table");
    }

    #[test]
    fn nan_parameters_do_not_panic() {
        let gb = buffer(&[(f32::NAN, f32::INFINITY), (0.5, 0.5)]);
        let (t, _) = MaterialTable::build(&gb, &[Attribute::Roughness, Attribute::Metallic], 1);
        assert!(t.entries.iter().flatten().all(|v| v.is_finite()));
    }

    #[test]
    fn keyed_by_material_id_one_entry_per_id_holding_the_mean() {
        // Three materials; the second has a textured roughness (0.2 and 0.4 → mean 0.3).
        let mut gb = buffer(&[(0.1, 0.0), (0.2, 1.0), (0.4, 1.0), (0.9, 0.5), (0.1, 0.0)]);
        gb.material_id = Some(vec![70, 12, 12, 900, 70]);
        let attrs = [Attribute::Roughness, Attribute::Metallic];
        let (t, idx) = MaterialTable::build_keyed(&gb, &attrs, 2, MaterialKey::Auto);
        assert_eq!((t.key.as_str(), t.ids.as_slice()), ("material-id", &[12, 70, 900][..]));
        assert_eq!(t.entries.len(), 3);
        assert_eq!(idx, [1, 0, 0, 2, 1], "the index is the ID's rank");
        assert!((t.entries[0][0] - 0.3).abs() < 1e-7 && t.entries[0][1] == 1.0);
        assert!(!t.lossless && (t.max_abs_error[0] - 0.1).abs() < 1e-6, "{:?}", t.max_abs_error);
        assert_eq!(t.max_abs_error[1], 0.0);
        assert_eq!(t.distinct_tuples, 4);
        // More IDs than 2^bits entries: a palette, and the table says why.
        let (t, _) = MaterialTable::build_keyed(&gb, &attrs, 1, MaterialKey::MaterialId);
        assert_eq!(t.key, "palette");
        assert!(t.note.as_deref().is_some_and(|n| n.contains("3 material IDs")), "{:?}", t.note);
        // Asked for a palette, or no IDs at all: the palette.
        assert_eq!(MaterialTable::build_keyed(&gb, &attrs, 2, MaterialKey::Palette).0.key, "palette");
        gb.material_id = None;
        let (t, _) = MaterialTable::build_keyed(&gb, &attrs, 2, MaterialKey::MaterialId);
        assert!(t.key == "palette" && t.note.is_some());
    }

    /// The distinct IDs and their ranks take a bitmap and a dense table below 2^20 and a hash set and a binary
    /// search above: both give the same table and index, with an uncovered sample's ID left out either way.
    #[test]
    fn small_and_large_ids_give_the_same_table() {
        let mut gb = buffer(&[(0.1, 0.0), (0.2, 1.0), (0.4, 1.0), (0.9, 0.5), (0.1, 0.0), (0.3, 0.3)]);
        gb.coverage[5] = false;
        let attrs = [Attribute::Roughness, Attribute::Metallic];
        let small = vec![70, 12, 12, 900, 70, 5];
        let large: Vec<u32> = small.iter().map(|&id| id + (1 << 24)).collect();
        gb.material_id = Some(small);
        let (a, ia) = MaterialTable::build_keyed(&gb, &attrs, 2, MaterialKey::MaterialId);
        gb.material_id = Some(large);
        let (b, ib) = MaterialTable::build_keyed(&gb, &attrs, 2, MaterialKey::MaterialId);
        assert_eq!(a.ids, [12, 70, 900], "the uncovered sample's ID 5 is not a material");
        assert_eq!(b.ids, a.ids.iter().map(|&id| id + (1 << 24)).collect::<Vec<_>>());
        assert_eq!((a.entries, ia), (b.entries, ib));
    }
}
