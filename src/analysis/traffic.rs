//! The one memory model of every pipeline gbuf compares: per frame, the bytes each render pass keeps resident
//! (footprint) and moves (traffic), as a table of terms over a few counts of the frame ([`Counts`]). The same terms
//! give the numbers (the pipelines table, each sweep row's [`Bandwidth`]) and the formulas printed beside them
//! (report.md, docs/GUIDE.md, whose table `tests/docs_traffic.rs` checks against [`markdown_table`]).
//!
//! Every count and coefficient is a whole number far below 2^53, so a total is exact in f64 whatever the order of
//! its terms.

use crate::analysis::row::Bandwidth;
use crate::gbuffer::GBuffer;
use serde::{Deserialize, Serialize};

crate::named_enum! {
    /// A rendering pipeline of the comparison.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
    #[serde(rename_all = "kebab-case")]
    pub enum Pipeline: "pipeline" {
        /// Forward shading, no MSAA: one sample per pixel, every light per fragment.
        Forward => "forward",
        /// Forward shading with MSAA: one shade per (triangle, pixel), in quads; every light per fragment.
        ForwardMsaa => "forward-msaa",
        /// Forward+ (tiled forward): a depth pre-pass, per-tile light lists stored in memory, then forward MSAA
        /// shading against the tile's list.
        ForwardPlus => "forward-plus",
        /// Deferred, each light a screen quad: the G-buffer read once per light-fragment pair.
        DeferredQuad => "deferred-quad",
        /// Tiled deferred (Andersson 2009, Lauritzen 2010): lights culled per tile in on-chip memory, the G-buffer
        /// read once; what `gbuf resolve` runs.
        TiledDeferred => "tiled-deferred",
        /// Deferred lighting (light pre-pass): a thin G-buffer, a light buffer, a second geometry pass.
        LightPrepass => "light-prepass",
        /// Visibility buffer: triangle ID + depth per sample, per-tile lists of (triangle, quad) fragments,
        /// attributes re-fetched from the meshes when shading.
        VisibilityBuffer => "visibility-buffer",
    }
}

/// A count of the frame a term multiplies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Var {
    /// Pixels.
    P,
    /// Samples per pixel.
    S,
    /// Covered samples (a surface, not background).
    C,
    /// Covered pixels (at least one covered sample).
    C1,
    /// The layout's bytes per sample.
    B,
    /// Light-fragment pairs of a quad-culled resolve.
    L,
    /// Forward+'s light-list bytes (4 B per entry, 8 B per tile).
    T,
    /// Fragment-list entries of the visibility buffer.
    F,
    /// The visibility layout's bytes per sample.
    V,
}

impl Var {
    /// Every count, in the order the legend lists them.
    pub const ALL: [Var; 9] = [Var::P, Var::S, Var::C, Var::C1, Var::B, Var::L, Var::T, Var::F, Var::V];

    /// Its symbol.
    #[must_use]
    pub fn symbol(self) -> &'static str {
        match self {
            Var::P => "P",
            Var::S => "S",
            Var::C => "C",
            Var::C1 => "C₁",
            Var::B => "B",
            Var::L => "L",
            Var::T => "T",
            Var::F => "F",
            Var::V => "V",
        }
    }

    /// What it counts.
    #[must_use]
    pub fn meaning(self) -> &'static str {
        match self {
            Var::P => "pixels",
            Var::S => "samples per pixel",
            Var::C => "covered samples",
            Var::C1 => "covered pixels",
            Var::B => "the layout's bytes per sample",
            Var::L => "the quad-culled resolve's light-fragment pairs",
            Var::T => "forward+'s light-list bytes (4 B per entry, 8 B per tile)",
            Var::F => "fragment-list entries",
            Var::V => "the visibility layout's bytes per sample",
        }
    }
}

/// A product of a coefficient and counts, or a count times a sum (`L·(B + 16)`).
#[derive(Clone, Copy, Debug)]
pub enum Expr {
    /// `coefficient · vars…` (a coefficient of 1 is not printed).
    Product(f64, &'static [Var]),
    /// `var · (var + constant)`.
    Times(Var, Var, f64),
}

/// One term of a footprint or a traffic: its value and what it is.
#[derive(Clone, Copy, Debug)]
pub struct Term {
    /// The expression.
    pub expr: Expr,
    /// What the bytes are (may be empty).
    pub what: &'static str,
}

const fn t(c: f64, vars: &'static [Var], what: &'static str) -> Term {
    Term { expr: Expr::Product(c, vars), what }
}

/// A footprint or a traffic: its terms, optionally after another pipeline's (forward+ adds to forward MSAA).
#[derive(Clone, Copy, Debug)]
pub struct Model {
    /// The pipeline whose model comes first, when this one extends it.
    pub base: Option<Pipeline>,
    /// The terms.
    pub terms: &'static [Term],
}

use Var::{B, C, C1, F, L, P, S, T, V};

impl Pipeline {
    /// Bytes resident per frame.
    #[must_use]
    fn footprint_model(self) -> Model {
        let own = |terms: &'static [Term]| Model { base: None, terms };
        match self {
            Pipeline::Forward => own(const { &[t(12.0, &[P], "D32 + RGBA16F")] }),
            Pipeline::ForwardMsaa => own(const { &[t(12.0, &[S, P], ""), t(8.0, &[P], "resolved output")] }),
            Pipeline::ForwardPlus => Model { base: Some(Pipeline::ForwardMsaa), terms: const { &[t(1.0, &[T], "")] } },
            Pipeline::DeferredQuad => own(const { &[t(1.0, &[B, S, P], ""), t(8.0, &[P], "output")] }),
            Pipeline::TiledDeferred => own(const { &[t(1.0, &[B, S, P], ""), t(8.0, &[P], "")] }),
            Pipeline::LightPrepass => {
                own(const { &[t(16.0, &[S, P], "thin G-buffer + light buffer"), t(8.0, &[P], "")] })
            }
            Pipeline::VisibilityBuffer => {
                own(const { &[t(1.0, &[V, S, P], "visibility layout"), t(8.0, &[F], "lists"), t(8.0, &[P], "")] })
            }
        }
    }

    /// Bytes moved per frame.
    #[must_use]
    pub fn traffic_model(self) -> Model {
        let own = |terms: &'static [Term]| Model { base: None, terms };
        match self {
            Pipeline::Forward => own(const { &[t(4.0, &[C1], "depth"), t(8.0, &[P], "colour")] }),
            Pipeline::ForwardMsaa => own(const {
                &[
                    t(4.0, &[C], "depth"),
                    t(8.0, &[C], "colour"),
                    t(8.0, &[C], "resolve read"),
                    t(8.0, &[P], "resolve write"),
                ]
            }),
            Pipeline::ForwardPlus => Model {
                base: Some(Pipeline::ForwardMsaa),
                terms: const { &[t(4.0, &[C], "depth read by the culling"), t(2.0, &[T], "light lists")] },
            },
            Pipeline::DeferredQuad => own(const {
                &[
                    t(1.0, &[B, C], "write"),
                    Term { expr: Expr::Times(L, B, 16.0), what: "G-buffer reads + RGBA16F read-modify-writes" },
                ]
            }),
            Pipeline::TiledDeferred => {
                own(const { &[t(1.0, &[B, C], "write"), t(1.0, &[B, C], "read"), t(8.0, &[P], "output")] })
            }
            Pipeline::LightPrepass => own(const {
                &[
                    t(8.0, &[C], "thin G-buffer write"),
                    t(8.0, &[C], "read"),
                    t(8.0, &[C], "light buffer write"),
                    t(8.0, &[C], "read"),
                    t(8.0, &[P], "output"),
                ]
            }),
            Pipeline::VisibilityBuffer => own(const {
                &[
                    t(1.0, &[V, C], "write"),
                    t(1.0, &[V, C], "read"),
                    t(16.0, &[F], "lists"),
                    t(96.0, &[F], "vertex fetch"),
                    t(8.0, &[P], "output"),
                ]
            }),
        }
    }
}

/// The counts of one frame the models are evaluated on; a count left `None` makes the terms that use it unknown.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Counts {
    /// Pixels.
    pub pixels: f64,
    /// Samples per pixel.
    pub samples: f64,
    /// Covered samples.
    pub covered: f64,
    /// Covered pixels.
    pub covered_pixels: f64,
    /// The layout's bytes per sample.
    pub bytes: f64,
    /// Light-fragment pairs of a quad-culled resolve.
    pub light_pairs: Option<f64>,
    /// Forward+'s light-list bytes.
    pub light_list_bytes: f64,
    /// Fragment-list entries.
    pub fragments: f64,
    /// The visibility layout's bytes per sample.
    pub visibility_bytes: f64,
}

impl Counts {
    /// The counts of `gb` (pixels, samples, covered samples and pixels) for a layout of `bytes` per sample; the
    /// rest zero or unknown.
    #[must_use]
    pub fn of(gb: &GBuffer, bytes: u32) -> Counts {
        let covered_pixels = gb.coverage.chunks_exact(gb.samples.max(1) as usize).filter(|c| c.contains(&true)).count();
        Counts {
            pixels: gb.pixel_count() as f64,
            samples: f64::from(gb.samples),
            covered: (gb.len() - gb.background_samples()) as f64,
            covered_pixels: covered_pixels as f64,
            bytes: f64::from(bytes),
            ..Counts::default()
        }
    }

    fn get(&self, v: Var) -> Option<f64> {
        Some(match v {
            Var::P => self.pixels,
            Var::S => self.samples,
            Var::C => self.covered,
            Var::C1 => self.covered_pixels,
            Var::B => self.bytes,
            Var::L => return self.light_pairs,
            Var::T => self.light_list_bytes,
            Var::F => self.fragments,
            Var::V => self.visibility_bytes,
        })
    }
}

impl Expr {
    /// Its value on `n`, `None` when a count it uses is unknown.
    #[must_use]
    pub fn eval(&self, n: &Counts) -> Option<f64> {
        match *self {
            Expr::Product(c, vars) => vars.iter().try_fold(c, |acc, &v| Some(acc * n.get(v)?)),
            Expr::Times(a, b, k) => Some(n.get(a)? * (n.get(b)? + k)),
        }
    }

    fn text(&self, md: bool) -> String {
        let sym = |v: Var| if md { format!("*{}*", v.symbol()) } else { v.symbol().to_string() };
        match *self {
            Expr::Product(c, vars) => {
                let mut parts: Vec<String> = Vec::new();
                if c != 1.0 || vars.is_empty() {
                    parts.push(format!("{c}"));
                }
                parts.extend(vars.iter().map(|&v| sym(v)));
                parts.join("·")
            }
            Expr::Times(a, b, k) => format!("{}·({} + {k})", sym(a), sym(b)),
        }
    }
}

impl Model {
    /// Its value on `n`: the base pipeline's model (`of` gives it: footprint or traffic), then this one's terms,
    /// summed in order; `None` when a count a term uses is unknown.
    fn eval(&self, of: fn(Pipeline) -> Model, n: &Counts) -> Option<f64> {
        let base = match self.base {
            Some(p) => of(p).eval(of, n)?,
            None => 0.0,
        };
        self.terms.iter().try_fold(base, |acc, term| Some(acc + term.expr.eval(n)?))
    }

    /// The formula: `4·C depth + 8·C colour + …` (`md`: counts in Markdown italics), the base pipeline by name.
    #[must_use]
    pub fn formula(&self, md: bool) -> String {
        let mut parts: Vec<String> = self.base.map(|p| p.to_string()).into_iter().collect();
        for term in self.terms {
            let e = term.expr.text(md);
            parts.push(if term.what.is_empty() { e } else { format!("{e} {}", term.what) });
        }
        parts.join(" + ")
    }
}

impl Pipeline {
    /// Bytes resident per frame on `n`.
    #[must_use]
    pub fn footprint(self, n: &Counts) -> Option<f64> {
        self.footprint_model().eval(Pipeline::footprint_model, n)
    }

    /// Bytes moved per frame on `n`.
    #[must_use]
    pub fn traffic(self, n: &Counts) -> Option<f64> {
        self.traffic_model().eval(Pipeline::traffic_model, n)
    }

    /// The traffic formula, plain text.
    #[must_use]
    pub fn bandwidth_formula(self) -> String {
        self.traffic_model().formula(false)
    }
}

/// `P pixels, S samples per pixel, …`: what the symbols of the formulas count.
#[must_use]
pub fn legend() -> String {
    Var::ALL.iter().map(|v| format!("{} {}", v.symbol(), v.meaning())).collect::<Vec<_>>().join(", ")
}

/// The footprint and traffic of every pipeline as the Markdown table of docs/GUIDE.md.
#[must_use]
pub fn markdown_table() -> String {
    use crate::base::table::{Align, Table};
    let mut t = Table::new([
        ("row", Align::Left),
        ("footprint (bytes)", Align::Left),
        ("traffic (bytes per frame)", Align::Left),
    ]);
    for p in Pipeline::ALL {
        t.row([p.to_string(), p.footprint_model().formula(true), p.traffic_model().formula(true)]);
    }
    t.finish()
}

/// Modelled traffic of a layout of `bytes` per sample on `gb` (see [`Bandwidth`]): the tiled-deferred and
/// deferred-quad models, in 10⁶ bytes per frame.
#[must_use]
pub fn bandwidth(gb: &GBuffer, bytes: impl Into<f64>, quad_light_fragments: Option<u64>) -> Bandwidth {
    // Only the counts these two models use (no pass over the coverage for covered pixels: this runs per sweep row).
    let n = Counts {
        pixels: gb.pixel_count() as f64,
        samples: f64::from(gb.samples),
        covered: (gb.len() - gb.background_samples()) as f64,
        bytes: bytes.into(),
        light_pairs: quad_light_fragments.map(|l| l as f64),
        ..Counts::default()
    };
    let tiled = Pipeline::TiledDeferred.traffic(&n).unwrap_or(f64::NAN);
    let quad = Pipeline::DeferredQuad.traffic(&n).map(|x| x / 1e6);
    Bandwidth { tiled: tiled / 1e6, quad, quad_light_fragments }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn counts() -> Counts {
        Counts {
            pixels: 100.0,
            samples: 4.0,
            covered: 300.0,
            covered_pixels: 90.0,
            bytes: 20.0,
            light_pairs: Some(1000.0),
            light_list_bytes: 64.0,
            fragments: 50.0,
            visibility_bytes: 8.0,
        }
    }

    /// The models give the formulas' numbers, written out by hand per pipeline.
    #[test]
    fn models_evaluate_their_formulas() {
        let n = counts();
        let (p, s, c, c1, b, l, tl, f, v) = (100.0, 4.0, 300.0, 90.0, 20.0, 1000.0, 64.0, 50.0, 8.0);
        let msaa_fp = 12.0 * s * p + 8.0 * p;
        let msaa = 4.0 * c + 8.0 * c + 8.0 * c + 8.0 * p;
        let want = [
            (Pipeline::Forward, 12.0 * p, 4.0 * c1 + 8.0 * p),
            (Pipeline::ForwardMsaa, msaa_fp, msaa),
            (Pipeline::ForwardPlus, msaa_fp + tl, msaa + 4.0 * c + 2.0 * tl),
            (Pipeline::DeferredQuad, b * s * p + 8.0 * p, b * c + l * (b + 16.0)),
            (Pipeline::TiledDeferred, b * s * p + 8.0 * p, 2.0 * b * c + 8.0 * p),
            (Pipeline::LightPrepass, 16.0 * s * p + 8.0 * p, 32.0 * c + 8.0 * p),
            (Pipeline::VisibilityBuffer, v * s * p + 8.0 * f + 8.0 * p, 2.0 * v * c + 112.0 * f + 8.0 * p),
        ];
        for (pl, fp, tr) in want {
            assert_eq!(pl.footprint(&n), Some(fp), "{pl} footprint");
            assert_eq!(pl.traffic(&n), Some(tr), "{pl} traffic");
        }
        let unknown = Counts { light_pairs: None, ..n };
        assert_eq!(Pipeline::DeferredQuad.traffic(&unknown), None);
        assert!(Pipeline::TiledDeferred.traffic(&unknown).is_some());
    }

    /// The counts of a frame, and the sweep's bandwidth from the same models.
    #[test]
    fn counts_of_a_frame_and_its_bandwidth() {
        let gb = crate::scene::render(crate::scene::SceneName::Room, 24, 16, 4).unwrap();
        let n = Counts::of(&gb, 20);
        let covered = gb.coverage.iter().filter(|c| **c).count() as f64;
        assert_eq!((n.pixels, n.samples, n.covered, n.bytes), (384.0, 4.0, covered, 20.0));
        assert!(n.covered_pixels >= (covered / 4.0).ceil() && n.covered_pixels <= covered.min(384.0));
        let bw = bandwidth(&gb, 20, Some(1000));
        assert_eq!(bw.tiled, Pipeline::TiledDeferred.traffic(&n).unwrap() / 1e6);
        assert_eq!(bw.quad, Some((20.0 * covered + 1000.0 * 36.0) / 1e6));
        assert_eq!(bandwidth(&gb, 20, None).quad, None);
    }

    /// The formulas print every term, the base pipeline by name, and the legend names every symbol used.
    #[test]
    fn formulas_read_as_written() {
        assert_eq!(Pipeline::Forward.bandwidth_formula(), "4·C₁ depth + 8·P colour");
        assert_eq!(
            Pipeline::ForwardPlus.bandwidth_formula(),
            "forward-msaa + 4·C depth read by the culling + 2·T light lists"
        );
        assert_eq!(
            Pipeline::DeferredQuad.bandwidth_formula(),
            "B·C write + L·(B + 16) G-buffer reads + RGBA16F read-modify-writes"
        );
        assert_eq!(Pipeline::ForwardPlus.footprint_model().formula(true), "forward-msaa + *T*");
        let legend = legend();
        for v in Var::ALL {
            assert!(legend.contains(&format!("{} {}", v.symbol(), v.meaning())), "{legend}");
        }
    }
}
