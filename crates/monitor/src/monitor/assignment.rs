//! Minimum-cost assignment of conflict clusters to objects within one small connected group of candidate pairs
//! (docs/attribution.md, step 3): as many objects as possible get a cluster, and among those assignments the one
//! with the smallest total displacement wins. A greedy "nearest pair first" rule can give one object's evidence
//! to a neighbour whose region happens to lie nearer and leave the object itself with nothing, although each
//! could have had its own (two pedestrians displaced side by side).
//!
//! The Hungarian algorithm (Kuhn-Munkres, the shortest-augmenting-path form) on a fixed-size matrix: no
//! allocation, bounded loops, no indexing that can panic. Rows are objects, columns clusters; every row also has
//! an "unassigned" column at a cost larger than any sum of admissible costs, so that more assigned rows always
//! win (lexicographic: cardinality first, then total cost).

/// Most objects, and most clusters, in one group solved exactly (larger groups fall back to nearest first).
pub(super) const MAX_SIDE: usize = 8;
const COLS: usize = 2 * MAX_SIDE;
/// Cost of a pair that is not a candidate.
const FORBIDDEN: f64 = 1.0e9;
/// Cost of leaving a row unassigned: above `MAX_SIDE` times any admissible cost (costs are gated distances, at
/// most 20 m by the parameters' range), below `FORBIDDEN`.
const UNASSIGNED: f64 = 1.0e6;

/// A `MAX_SIDE x MAX_SIDE` cost matrix: `cost[row][column]`, `f32::INFINITY` (or any non-finite value) where the
/// pair is not a candidate.
pub(super) type Costs = [[f32; MAX_SIDE]; MAX_SIDE];

fn get<T: Copy + Default, const N: usize>(a: &[T; N], i: usize) -> T {
    a.get(i).copied().unwrap_or_default()
}

fn set<T, const N: usize>(a: &mut [T; N], i: usize, value: T) {
    if let Some(x) = a.get_mut(i) {
        *x = value;
    }
}

/// For each of the first `rows` rows, the column (of the first `cols`) it is assigned, or `None`. Maximises the
/// number of assigned rows, then minimises the sum of their costs; ties go to the assignment the algorithm meets
/// first (deterministic for a given matrix).
pub(super) fn assign(rows: usize, cols: usize, cost: &Costs) -> [Option<u8>; MAX_SIDE] {
    let mut out = [None; MAX_SIDE];
    let (n, cols) = (rows.min(MAX_SIDE), cols.min(MAX_SIDE));
    let m = cols + n;
    // 1-based, as in the textbook form: row 0 and column 0 are the algorithm's sentinels.
    let a = |i: usize, j: usize| -> f64 {
        if j <= cols {
            match cost.get(i.wrapping_sub(1)).and_then(|r| r.get(j.wrapping_sub(1))) {
                Some(&c) if c.is_finite() => f64::from(c),
                _ => FORBIDDEN,
            }
        } else {
            UNASSIGNED
        }
    };
    let mut u = [0.0f64; MAX_SIDE + 1];
    let mut v = [0.0f64; COLS + 1];
    let mut p = [0usize; COLS + 1];
    let mut way = [0usize; COLS + 1];
    for i in 1..=n {
        set(&mut p, 0, i);
        let mut j0 = 0usize;
        let mut minv = [f64::INFINITY; COLS + 1];
        let mut used = [false; COLS + 1];
        // Each pass marks one more column used: at most m + 1 passes.
        for _ in 0..=m {
            set(&mut used, j0, true);
            let i0 = get(&p, j0);
            let (mut delta, mut j1) = (f64::INFINITY, 0usize);
            for j in 1..=m {
                if !get(&used, j) {
                    let cur = a(i0, j) - get(&u, i0) - get(&v, j);
                    if cur < get(&minv, j) {
                        set(&mut minv, j, cur);
                        set(&mut way, j, j0);
                    }
                    if get(&minv, j) < delta {
                        delta = get(&minv, j);
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if get(&used, j) {
                    let pj = get(&p, j);
                    let x = get(&u, pj) + delta;
                    set(&mut u, pj, x);
                    let x = get(&v, j) - delta;
                    set(&mut v, j, x);
                } else {
                    let x = get(&minv, j) - delta;
                    set(&mut minv, j, x);
                }
            }
            j0 = j1;
            if get(&p, j0) == 0 {
                break;
            }
        }
        for _ in 0..=m {
            let j1 = get(&way, j0);
            let x = get(&p, j1);
            set(&mut p, j0, x);
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    for j in 1..=cols {
        let i = get(&p, j);
        if i != 0 && a(i, j) < UNASSIGNED {
            if let Some(o) = out.get_mut(i - 1) {
                *o = u8::try_from(j - 1).ok();
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute force over every partial assignment: (assigned rows, total cost) of the best.
    fn best(rows: usize, cols: usize, cost: &Costs) -> (usize, f64) {
        fn go(
            r: usize,
            rows: usize,
            cols: usize,
            cost: &Costs,
            used: &mut [bool; MAX_SIDE],
            acc: (usize, f64),
        ) -> (usize, f64) {
            if r == rows {
                return acc;
            }
            let mut b = go(r + 1, rows, cols, cost, used, acc);
            for c in 0..cols {
                let x = cost[r][c];
                if !used[c] && x.is_finite() {
                    used[c] = true;
                    let got = go(r + 1, rows, cols, cost, used, (acc.0 + 1, acc.1 + f64::from(x)));
                    used[c] = false;
                    if got.0 > b.0 || (got.0 == b.0 && got.1 < b.1 - 1e-9) {
                        b = got;
                    }
                }
            }
            b
        }
        go(0, rows, cols, cost, &mut [false; MAX_SIDE], (0, 0.0))
    }

    #[test]
    fn each_object_gets_its_own_cluster_rather_than_the_nearest() {
        // Object 0 is nearest to cluster 0 (0.5), but object 1 can only have cluster 0 (1.5); object 0 can also
        // have cluster 1 (1.0). Nearest first gives object 0 cluster 0 and object 1 nothing.
        let mut c = [[f32::INFINITY; MAX_SIDE]; MAX_SIDE];
        c[0][0] = 0.5;
        c[0][1] = 1.0;
        c[1][0] = 1.5;
        let got = assign(2, 2, &c);
        assert_eq!(got[0], Some(1));
        assert_eq!(got[1], Some(0));
        // Nothing admissible: nobody is assigned.
        let none = assign(3, 3, &[[f32::INFINITY; MAX_SIDE]; MAX_SIDE]);
        assert!(none.iter().all(Option::is_none));
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 400, .. ProptestConfig::default() })]

        /// The assignment is valid (each column at most once, only admissible pairs) and as good as the best found
        /// by brute force: as many rows assigned, and no larger total cost.
        #[test]
        fn matches_brute_force(
            rows in 0usize..=6,
            cols in 0usize..=6,
            raw in proptest::collection::vec(prop_oneof![2 => (0.0f32..2.0).prop_map(Some), 1 => Just(None)], 64),
        ) {
            let mut c = [[f32::INFINITY; MAX_SIDE]; MAX_SIDE];
            for r in 0..rows {
                for k in 0..cols {
                    if let Some(x) = raw[r * 8 + k] {
                        c[r][k] = x;
                    }
                }
            }
            let got = assign(rows, cols, &c);
            let mut used = [false; MAX_SIDE];
            let (mut n, mut total) = (0usize, 0.0f64);
            for (r, g) in got.iter().enumerate() {
                if let Some(k) = g {
                    let k = usize::from(*k);
                    prop_assert!(r < rows && k < cols && !used[k] && c[r][k].is_finite());
                    used[k] = true;
                    n += 1;
                    total += f64::from(c[r][k]);
                }
            }
            let (bn, bt) = best(rows, cols, &c);
            prop_assert_eq!(n, bn);
            prop_assert!(total <= bt + 1e-4, "{} > {}", total, bt);
        }
    }
}
