//! [`EdgeMask`]: which pixels a deferred renderer shades per sample, as shading evaluations per pixel. Edge
//! detectors and baselines (`detect`) produce it; the resolve, the measures and the pictures read it.

/// The result of an edge detector: per pixel, how many shading evaluations it asks for.
///
/// `shade_count[p]` is 0 for a pixel with no covered sample, 1 for a pixel shaded once (sample 0 stands for the
/// pixel), and `samples` for a pixel shaded per sample. Baselines such as `forward-msaa` may ask for counts in
/// between (one evaluation per distinct primitive); the resolve shades such pixels per sample.
#[derive(Clone, Debug, PartialEq)]
pub struct EdgeMask {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub samples: u32,
    /// Shading evaluations per pixel, row-major.
    pub shade_count: Vec<u8>,
}

impl EdgeMask {
    /// A mask of the given size with every pixel at `count` evaluations.
    #[must_use]
    pub fn filled(width: u32, height: u32, samples: u32, count: u8) -> Self {
        EdgeMask { width, height, samples, shade_count: vec![count; width as usize * height as usize] }
    }

    /// Does pixel `p` (row-major index) need per-sample shading?
    #[inline]
    #[must_use]
    pub fn is_edge(&self, p: usize) -> bool {
        self.shade_count[p] > 1
    }

    /// Number of pixels flagged as edges.
    #[must_use]
    pub fn edge_pixels(&self) -> usize {
        self.shade_count.iter().filter(|&&c| c > 1).count()
    }

    /// Total shading evaluations asked for (the numerator of [`EdgeMask::shading_fraction`]).
    #[must_use]
    pub fn shaded_samples(&self) -> u64 {
        self.shade_count.iter().map(|&c| u64::from(c)).sum()
    }

    /// Per-pixel edge flags, row-major.
    #[must_use]
    pub fn edges(&self) -> Vec<bool> {
        self.shade_count.iter().map(|&c| c > 1).collect()
    }

    /// Fraction of pixels flagged as edges.
    #[must_use]
    pub fn edge_fraction(&self) -> f64 {
        if self.shade_count.is_empty() {
            return 0.0;
        }
        self.edge_pixels() as f64 / self.shade_count.len() as f64
    }

    /// Shading evaluations the mask costs on a G-buffer whose pixel `p` has `covered[p]` covered samples — what
    /// the resolve shades: a pixel shaded once costs its count (0 or 1); a pixel shaded per sample costs one
    /// evaluation per covered sample, never more than its count. Background samples are never shaded, so `ssaa`
    /// (`samples` for every pixel with any coverage) costs exactly the covered samples. [`Self::shaded_samples`]
    /// is what the mask asks for, which over-counts pixels that mix surface and background.
    #[must_use]
    pub fn evaluations(&self, covered: &[u8]) -> u64 {
        debug_assert_eq!(covered.len(), self.shade_count.len());
        self.shade_count.iter().zip(covered).map(|(&c, &k)| u64::from(if c > 1 { c.min(k) } else { c })).sum()
    }

    /// [`Self::evaluations`] / (pixels × samples): the shading fraction reports and `gbuf edges` show.
    #[must_use]
    pub fn evaluated_fraction(&self, covered: &[u8]) -> f64 {
        let total = self.shade_count.len() as f64 * f64::from(self.samples);
        if total == 0.0 {
            return 0.0;
        }
        self.evaluations(covered) as f64 / total
    }

    /// Shaded samples / (pixels × samples): what the mask asks for (see [`Self::evaluated_fraction`] for what it
    /// costs).
    #[must_use]
    pub fn shading_fraction(&self) -> f64 {
        let total = self.shade_count.len() as f64 * f64::from(self.samples);
        if total == 0.0 {
            return 0.0;
        }
        self.shaded_samples() as f64 / total
    }
}
