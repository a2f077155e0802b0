//! Edge detectors for MSAA deferred shading: which pixels need per-sample shading.

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
    /// Does pixel `p` (row-major index) need per-sample shading?
    #[inline]
    #[must_use]
    pub fn is_edge(&self, p: usize) -> bool {
        self.shade_count[p] > 1
    }

    /// Fraction of pixels flagged as edges.
    #[must_use]
    pub fn edge_fraction(&self) -> f64 {
        if self.shade_count.is_empty() {
            return 0.0;
        }
        self.shade_count.iter().filter(|&&c| c > 1).count() as f64 / self.shade_count.len() as f64
    }

    /// Shaded samples / (pixels × samples).
    #[must_use]
    pub fn shading_fraction(&self) -> f64 {
        let total = self.shade_count.len() as f64 * f64::from(self.samples);
        if total == 0.0 {
            return 0.0;
        }
        self.shade_count.iter().map(|&c| f64::from(c)).sum::<f64>() / total
    }
}
