//! The cells FastDTW evaluates at one level (the `fastdtw` package's `__expand_window`): the
//! coarser level's warping path, widened by `radius` cells in every direction (diagonals too),
//! then each coarse cell doubled into its four finer cells.
//!
//! The package builds that set cell by cell and then keeps, in each row, the first run of cells
//! at or after the previous row's first column. The widened path of a monotone path is one run
//! per row whose ends never move left from row to row, so a row is exactly one interval: for fine
//! row `i` and coarse row `a = i / 2`, the path's columns in coarse rows `a - radius ..= a + radius`
//! span `first[max(0, a - r)] ..= last[min(rows - 1, a + r)]`, widened by `r` and doubled. With
//! radius 0 and an odd length that leaves the last row or column out, where the package fails.

/// Per row `i`, the columns `lo[i]..end[i]` (empty when `lo == end`), and where the row starts
/// in the flat DP buffer (`off[i]`).
#[derive(Debug, Clone, Default)]
pub(crate) struct Window {
    pub(crate) lo: Vec<usize>,
    pub(crate) end: Vec<usize>,
    pub(crate) off: Vec<usize>,
    /// The number of cells.
    pub(crate) cells: usize,
}

impl Window {
    /// Every cell of an `n` x `m` grid (the base level's full DTW).
    pub(crate) fn full(&mut self, n: usize, m: usize) {
        self.clear();
        for _ in 0..n {
            self.push(0, m);
        }
    }

    /// The window of an `n` x `m` level around the coarser level's path, given by its first and
    /// last column in each coarse row (`first.len()` coarse rows, all on the path).
    pub(crate) fn expand(&mut self, first: &[usize], last: &[usize], n: usize, m: usize, radius: usize) {
        self.clear();
        let rows = first.len();
        for i in 0..n {
            let a = i / 2;
            if a > rows - 1 + radius {
                // No path cell within `radius` rows: the package's window has nothing here.
                self.push(m, m);
                continue;
            }
            let lo = first[a.saturating_sub(radius)].saturating_sub(radius);
            let hi = last[(a + radius).min(rows - 1)] + radius;
            self.push((2 * lo).min(m), (2 * hi + 2).min(m));
        }
    }

    fn clear(&mut self) {
        self.lo.clear();
        self.end.clear();
        self.off.clear();
        self.cells = 0;
    }

    fn push(&mut self, lo: usize, end: usize) {
        self.lo.push(lo);
        self.end.push(end);
        self.off.push(self.cells);
        self.cells += end - lo;
    }

    /// Where cell `(i, j)` is in the DP buffer, if it is in the window.
    #[inline]
    pub(crate) fn index(&self, i: usize, j: usize) -> Option<usize> {
        (j >= self.lo[i] && j < self.end[i]).then(|| self.off[i] + j - self.lo[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The package's construction, cell by cell (its `__expand_window`, written from its text).
    fn by_cells(path: &[(usize, usize)], n: usize, m: usize, r: usize) -> Vec<(usize, usize)> {
        let r = r as i64;
        let mut widened = std::collections::HashSet::new();
        for &(i, j) in path {
            for a in -r..=r {
                for b in -r..=r {
                    widened.insert((i as i64 + a, j as i64 + b));
                }
            }
        }
        let mut fine = std::collections::HashSet::new();
        for &(i, j) in &widened {
            for (a, b) in [(2 * i, 2 * j), (2 * i, 2 * j + 1), (2 * i + 1, 2 * j), (2 * i + 1, 2 * j + 1)] {
                fine.insert((a, b));
            }
        }
        let mut out = Vec::new();
        let mut start = 0;
        for i in 0..n as i64 {
            let mut new_start = None;
            for j in start..m as i64 {
                if fine.contains(&(i, j)) {
                    out.push((i as usize, j as usize));
                    new_start.get_or_insert(j);
                } else if new_start.is_some() {
                    break;
                }
            }
            match new_start {
                Some(s) => start = s,
                None => break,
            }
        }
        out
    }

    #[test]
    fn matches_the_cell_by_cell_construction() {
        // Monotone paths over small coarse grids, every radius up to 3, odd and even fine sizes.
        let mut state = 7u32;
        for _ in 0..300 {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let (rows, cols) = (1 + (state >> 8) as usize % 9, 1 + (state >> 16) as usize % 9);
            let mut path = vec![(0, 0)];
            let (mut i, mut j) = (0, 0);
            let mut s = state;
            while (i, j) != (rows - 1, cols - 1) {
                s = s.wrapping_mul(1_103_515_245).wrapping_add(12345);
                match (s >> 16) % 3 {
                    0 if i + 1 < rows => i += 1,
                    1 if j + 1 < cols => j += 1,
                    _ if i + 1 < rows && j + 1 < cols => (i, j) = (i + 1, j + 1),
                    _ if i + 1 < rows => i += 1,
                    _ => j += 1,
                }
                path.push((i, j));
            }
            let mut first = vec![usize::MAX; rows];
            let mut last = vec![0; rows];
            for &(i, j) in &path {
                first[i] = first[i].min(j);
                last[i] = last[i].max(j);
            }
            for r in 0..=3 {
                for (n, m) in [(2 * rows, 2 * cols), (2 * rows + 1, 2 * cols + 1), (2 * rows + 1, 2 * cols)] {
                    let mut w = Window::default();
                    w.expand(&first, &last, n, m, r);
                    let ours: Vec<(usize, usize)> =
                        (0..n).flat_map(|i| (w.lo[i]..w.end[i]).map(move |j| (i, j))).collect();
                    assert_eq!(ours, by_cells(&path, n, m, r), "{path:?} {n}x{m} r={r}");
                }
            }
        }
    }
}
