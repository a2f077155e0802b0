//! The Pareto front of (cost, error) points: the layouts (or layout × detector runs) that no other one beats on
//! both axes at once. Both axes are "lower is better" (bytes per sample or run time; image error).
//!
//! A point is on the front when no other point *dominates* it, i.e. is no worse on both axes and strictly better
//! on one. Two identical points do not dominate each other, so ties are both on the front. Non-finite values
//! (a row that could not be computed carries NaN) are never on the front and never dominate anything.

/// Is `a` at least as good as `b` on both axes and strictly better on one? Lower is better.
#[must_use]
pub fn dominates(a: (f64, f64), b: (f64, f64)) -> bool {
    a.0 <= b.0 && a.1 <= b.1 && (a.0 < b.0 || a.1 < b.1)
}

fn finite(p: (f64, f64)) -> bool {
    p.0.is_finite() && p.1.is_finite()
}

/// For each point `(cost, error)`, whether it is on the Pareto front. O(n²), fine for the few hundred rows of a
/// sweep.
#[must_use]
pub fn front(points: &[(f64, f64)]) -> Vec<bool> {
    points.iter().map(|&p| finite(p) && !points.iter().any(|&q| finite(q) && dominates(q, p))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The indices of the front sorted by cost (then error).
    fn front_polyline(points: &[(f64, f64)]) -> Vec<usize> {
        let on = front(points);
        let mut idx: Vec<usize> = (0..points.len()).filter(|&i| on[i]).collect();
        idx.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0).then(points[a].1.total_cmp(&points[b].1)));
        idx
    }

    #[test]
    fn hand_built_front() {
        // (bytes, error): 0 and 2 and 4 are the front; 1 is dominated by 0, 3 by 2.
        let pts = [(8.0, 1.0), (12.0, 1.5), (12.0, 0.5), (16.0, 0.6), (20.0, 0.1)];
        assert_eq!(front(&pts), vec![true, false, true, false, true]);
        assert_eq!(front_polyline(&pts), vec![0, 2, 4]);
    }

    #[test]
    fn ties_are_all_on_the_front_and_equal_cost_keeps_the_better() {
        let pts = [(8.0, 1.0), (8.0, 1.0), (8.0, 2.0)];
        assert_eq!(front(&pts), vec![true, true, false]);
        let pts = [(8.0, 1.0), (10.0, 1.0)];
        assert_eq!(front(&pts), vec![true, false]);
    }

    #[test]
    fn non_finite_points_are_never_on_the_front_and_never_dominate() {
        let pts = [(8.0, f64::NAN), (0.0, f64::NEG_INFINITY), (12.0, 1.0), (f64::NAN, 0.0)];
        assert_eq!(front(&pts), vec![false, false, true, false]);
        assert_eq!(front_polyline(&pts), vec![2]);
    }

    #[test]
    fn every_point_off_the_front_is_dominated_by_one_on_it() {
        let mut rng = crate::base::rng::SplitMix64::new(3);
        let pts: Vec<(f64, f64)> =
            (0..200).map(|_| (f64::from(rng.range_f32(0.0, 10.0)), f64::from(rng.range_f32(0.0, 10.0)))).collect();
        let on = front(&pts);
        assert!(on.iter().any(|&b| b));
        for (i, &p) in pts.iter().enumerate() {
            let dominated_by_front = pts.iter().zip(&on).any(|(&q, &f)| f && dominates(q, p));
            assert_eq!(on[i], !dominated_by_front, "point {i} {p:?}");
        }
        // The front is monotone: cost up, error down.
        let line = front_polyline(&pts);
        for w in line.windows(2) {
            assert!(pts[w[0]].0 <= pts[w[1]].0 && pts[w[0]].1 >= pts[w[1]].1);
        }
    }

    #[test]
    fn empty_input() {
        assert!(front(&[]).is_empty());
    }
}
