//! A bounding volume hierarchy over triangles: binned SAH build, stack-based nearest-hit traversal.
//!
//! The scenes hold a few thousand to a few tens of thousands of triangles; a flat array of nodes with children
//! stored in pairs keeps traversal cache-friendly, which is what lets 1920×1080 at 4× MSAA (8.3 M rays) render in
//! seconds.

use super::geometry::Triangle;
use glam::Vec3;

/// Triangles per leaf at most.
const MAX_LEAF: usize = 4;
/// SAH bins per split.
const BINS: usize = 16;
/// Slack on the barycentric tests so a ray through an edge shared by two triangles hits at least one of them
/// (plain Möller–Trumbore can miss both by one ulp, leaving a background speck inside a surface).
const EDGE_SLACK: f32 = 1e-6;
/// Traversal stack size; the build depth is bounded by it (a 2^32-triangle tree needs ≈ 32 levels).
const STACK: usize = 64;

#[derive(Clone, Copy, Debug)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };
    fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    fn union(self, o: Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }
    fn area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

/// Node: an interior node's children are `first` and `first + 1`; a leaf (`count > 0`) holds triangles
/// `first .. first + count` of the reordered array.
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    first: u32,
    count: u32,
}

/// Intersection data of one triangle, in BVH order.
#[derive(Clone, Copy, Debug)]
struct TriGeom {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
}

/// The nearest hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter: the hit point is `origin + t · dir`.
    pub t: f32,
    /// Index of the triangle in the mesh's triangle list.
    pub tri: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
}

/// The hierarchy.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    tris: Vec<TriGeom>,
    /// BVH order → mesh triangle index.
    order: Vec<u32>,
}

impl Bvh {
    /// Builds the hierarchy over `triangles` (binned SAH).
    #[must_use]
    pub fn build(triangles: &[Triangle]) -> Bvh {
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let bounds: Vec<Aabb> = triangles
            .iter()
            .map(|t| {
                let mut b = Aabb::EMPTY;
                t.v.iter().for_each(|&p| b.grow(p));
                b
            })
            .collect();
        let centroids: Vec<Vec3> = bounds.iter().map(|b| (b.min + b.max) * 0.5).collect();
        let mut nodes = vec![Node { bounds: Aabb::EMPTY, first: 0, count: triangles.len() as u32 }];
        if !triangles.is_empty() {
            subdivide(&mut nodes, 0, &mut order, &bounds, &centroids, 0);
        }
        let tris = order
            .iter()
            .map(|&i| {
                let t = &triangles[i as usize];
                TriGeom { v0: t.v[0], e1: t.v[1] - t.v[0], e2: t.v[2] - t.v[0] }
            })
            .collect();
        Bvh { nodes, tris, order }
    }

    /// The nearest hit with `t` in `(t_min, t_max)` of the ray `origin + t · dir`, if any.
    #[must_use]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<Hit> {
        if self.tris.is_empty() {
            return None;
        }
        let inv = dir.recip();
        let mut best: Option<Hit> = None;
        let mut t_far = t_max;
        let mut stack = [0u32; STACK];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            if n.count > 0 {
                for k in n.first..n.first + n.count {
                    if let Some((t, u, v)) = intersect_tri(&self.tris[k as usize], origin, dir, t_min, t_far) {
                        t_far = t;
                        best = Some(Hit { t, tri: self.order[k as usize], u, v });
                    }
                }
            } else {
                let (a, b) = (n.first, n.first + 1);
                let ta = slab(&self.nodes[a as usize].bounds, origin, inv, t_min, t_far);
                let tb = slab(&self.nodes[b as usize].bounds, origin, inv, t_min, t_far);
                match (ta, tb) {
                    (Some(ta), Some(tb)) => {
                        let (near, far) = if ta <= tb { (a, b) } else { (b, a) };
                        stack[sp] = far;
                        sp += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = a;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = b;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            if sp == 0 {
                return best;
            }
            sp -= 1;
            node = stack[sp];
        }
    }
}

fn subdivide(nodes: &mut Vec<Node>, idx: usize, order: &mut [u32], bounds: &[Aabb], cent: &[Vec3], depth: usize) {
    let (first, count) = (nodes[idx].first as usize, nodes[idx].count as usize);
    let items = &mut order[first..first + count];
    let mut nb = Aabb::EMPTY;
    let mut cb = Aabb::EMPTY;
    for &i in items.iter() {
        nb = nb.union(bounds[i as usize]);
        cb.grow(cent[i as usize]);
    }
    nodes[idx].bounds = nb;
    if count <= MAX_LEAF || depth + 2 >= STACK {
        return;
    }
    // Binned SAH over the widest centroid axis.
    let ext = cb.max - cb.min;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = if ext[axis] <= 0.0 {
        count / 2 // all centroids coincide: split the list in half
    } else {
        let bin_of = |i: u32| {
            let f = (cent[i as usize][axis] - cb.min[axis]) / ext[axis] * BINS as f32;
            (f as usize).min(BINS - 1)
        };
        let mut bin_bounds = [Aabb::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for &i in items.iter() {
            let b = bin_of(i);
            bin_count[b] += 1;
            bin_bounds[b] = bin_bounds[b].union(bounds[i as usize]);
        }
        let mut best = (f32::INFINITY, 0usize);
        for split in 1..BINS {
            let (mut lb, mut rb) = (Aabb::EMPTY, Aabb::EMPTY);
            let (mut lc, mut rc) = (0, 0);
            for b in 0..split {
                lb = lb.union(bin_bounds[b]);
                lc += bin_count[b];
            }
            for b in split..BINS {
                rb = rb.union(bin_bounds[b]);
                rc += bin_count[b];
            }
            if lc == 0 || rc == 0 {
                continue;
            }
            let cost = lb.area() * lc as f32 + rb.area() * rc as f32;
            if cost < best.0 {
                best = (cost, split);
            }
        }
        if best.0.is_infinite() {
            count / 2
        } else {
            let split = best.1;
            let mut l = 0;
            for k in 0..count {
                if bin_of(items[k]) < split {
                    items.swap(k, l);
                    l += 1;
                }
            }
            l
        }
    };
    let mid = if mid == 0 || mid == count { count / 2 } else { mid };
    let left = nodes.len();
    nodes.push(Node { bounds: Aabb::EMPTY, first: first as u32, count: mid as u32 });
    nodes.push(Node { bounds: Aabb::EMPTY, first: (first + mid) as u32, count: (count - mid) as u32 });
    nodes[idx].first = left as u32;
    nodes[idx].count = 0;
    subdivide(nodes, left, order, bounds, cent, depth + 1);
    subdivide(nodes, left + 1, order, bounds, cent, depth + 1);
}

/// Entry distance of the ray into `b` within (t_min, t_max), if it enters. `f32::min`/`max` drop the NaN that
/// `0 · ∞` gives for a ray lying in a slab plane.
#[inline]
fn slab(b: &Aabb, o: Vec3, inv: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
    let t1 = (b.min - o) * inv;
    let t2 = (b.max - o) * inv;
    let lo = t1.min(t2);
    let hi = t1.max(t2);
    let enter = lo.x.max(lo.y).max(lo.z).max(t_min);
    let exit = hi.x.min(hi.y).min(hi.z).min(t_max);
    (enter <= exit).then_some(enter)
}

/// The ray `o + t·d` against one triangle, exactly as the traversal tests it: `(t, u, v)` with `t` in
/// `(t_min, t_max)` (re-materialisation re-intersects a sample's own triangle with it and gets the renderer's hit).
#[must_use]
pub fn intersect_triangle(t: &Triangle, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
    intersect_tri(&TriGeom { v0: t.v[0], e1: t.v[1] - t.v[0], e2: t.v[2] - t.v[0] }, o, d, t_min, t_max)
}

/// Möller–Trumbore, two-sided, with [`EDGE_SLACK`] on the barycentric bounds.
#[inline]
fn intersect_tri(tri: &TriGeom, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
    let p = d.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - tri.v0;
    let u = s.dot(p) * inv;
    if !(-EDGE_SLACK..=1.0 + EDGE_SLACK).contains(&u) {
        return None;
    }
    let q = s.cross(tri.e1);
    let v = d.dot(q) * inv;
    if v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
        return None;
    }
    let t = tri.e2.dot(q) * inv;
    (t > t_min && t < t_max).then_some((t, u, v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;

    fn random_soup(n: usize, seed: u64) -> Vec<Triangle> {
        let mut rng = SplitMix64::new(seed);
        (0..n)
            .map(|i| {
                let c = Vec3::new(rng.range_f32(-5.0, 5.0), rng.range_f32(-5.0, 5.0), rng.range_f32(-20.0, -1.0));
                let mut r = || Vec3::new(rng.range_f32(-0.5, 0.5), rng.range_f32(-0.5, 0.5), rng.range_f32(-0.5, 0.5));
                Triangle { v: [c + r(), c + r(), c + r()], n: [Vec3::Z; 3], smooth: false, object: 0, prim: i as u32 }
            })
            .collect()
    }

    fn brute(tris: &[Triangle], d: Vec3) -> Option<(f32, u32)> {
        let mut best = None;
        let mut far = f32::INFINITY;
        for (i, t) in tris.iter().enumerate() {
            let g = TriGeom { v0: t.v[0], e1: t.v[1] - t.v[0], e2: t.v[2] - t.v[0] };
            if let Some((t, _, _)) = intersect_tri(&g, Vec3::ZERO, d, 0.0, far) {
                far = t;
                best = Some((t, i as u32));
            }
        }
        best
    }

    #[test]
    fn bvh_agrees_with_brute_force() {
        let tris = random_soup(500, 3);
        let bvh = Bvh::build(&tris);
        let mut rng = SplitMix64::new(9);
        let mut hits = 0;
        for _ in 0..2000 {
            let d = Vec3::new(rng.range_f32(-0.4, 0.4), rng.range_f32(-0.4, 0.4), -1.0);
            let a = bvh.intersect(Vec3::ZERO, d, 0.0, f32::INFINITY).map(|h| (h.t, h.tri));
            assert_eq!(a, brute(&tris, d), "ray {d}");
            hits += usize::from(a.is_some());
        }
        assert!(hits > 200, "only {hits} hits: the test exercises little");
    }

    #[test]
    fn empty_and_degenerate_inputs() {
        assert!(Bvh::build(&[]).intersect(Vec3::ZERO, Vec3::NEG_Z, 0.0, 1e9).is_none());
        // Many triangles at the same place: the build must terminate and find them.
        let t = Triangle {
            v: [Vec3::new(-1.0, -1.0, -2.0), Vec3::new(1.0, -1.0, -2.0), Vec3::new(0.0, 1.0, -2.0)],
            n: [Vec3::Z; 3],
            smooth: false,
            object: 0,
            prim: 0,
        };
        let bvh = Bvh::build(&vec![t; 100]);
        let h = bvh.intersect(Vec3::ZERO, Vec3::NEG_Z, 0.0, 1e9).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6);
    }

    #[test]
    fn shared_edge_never_leaks() {
        // A quad split along its diagonal; rays exactly on the diagonal must hit.
        let (a, b, c, d) = (
            Vec3::new(-1.0, -1.0, -3.0),
            Vec3::new(1.0, -1.0, -3.0),
            Vec3::new(1.0, 1.0, -3.0),
            Vec3::new(-1.0, 1.0, -3.0),
        );
        let mk = |v| Triangle { v, n: [Vec3::Z; 3], smooth: false, object: 0, prim: 0 };
        let bvh = Bvh::build(&[mk([a, b, c]), mk([a, c, d])]);
        for k in 0..=100 {
            let s = -0.3 + 0.6 * k as f32 / 100.0;
            assert!(bvh.intersect(Vec3::ZERO, Vec3::new(s, s, -3.0), 0.0, 1e9).is_some(), "leak at {s}");
        }
    }
}
