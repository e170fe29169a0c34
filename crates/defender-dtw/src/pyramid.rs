//! FastDTW's coarsened copies of a sequence (the `fastdtw` package's `__reduce_by_half`): level 0
//! is the sequence in f64, level `l + 1` averages the pairs `(0, 1), (2, 3), ..` of level `l`
//! (an odd last element is dropped), down to one element.
//!
//! Levels are stored dimension-major (`data[start + k * len + j]`, component `k` of element `j`),
//! so that the local costs of one DP row read each component contiguously over `j`.

/// All the levels of one sequence, in one buffer that is reused when rebuilt.
#[derive(Debug, Clone, Default)]
pub(crate) struct Pyramid {
    pub(crate) dim: usize,
    /// `lens[l]`: the number of elements of level `l` (`lens[0]` the sequence's).
    pub(crate) lens: Vec<usize>,
    starts: Vec<usize>,
    data: Vec<f64>,
}

/// One level: `len` elements of `dim` components, dimension-major.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Level<'a> {
    pub(crate) data: &'a [f64],
    pub(crate) len: usize,
}

impl Level<'_> {
    /// Component `k` of every element.
    #[inline(always)]
    pub(crate) fn component(&self, k: usize) -> &[f64] {
        &self.data[k * self.len..(k + 1) * self.len]
    }
}

impl Pyramid {
    /// The levels of `seq` (row-major, `dim` values per element, at least one element).
    pub(crate) fn new(seq: &[f32], dim: usize) -> Self {
        let mut p = Self::default();
        p.rebuild(seq, dim);
        p
    }

    /// Replaces the levels with those of `seq`, reusing the buffers (no allocation once they have
    /// held a sequence as long).
    pub(crate) fn rebuild(&mut self, seq: &[f32], dim: usize) {
        let n = seq.len() / dim;
        self.layout(n, dim);
        for (j, row) in seq.chunks_exact(dim).enumerate() {
            for (k, &v) in row.iter().enumerate() {
                self.data[k * n + j] = f64::from(v);
            }
        }
        self.coarsen();
    }

    /// Replaces the levels with those of the last `count` elements of `src`'s sequence.
    pub(crate) fn rebuild_tail(&mut self, src: &Pyramid, count: usize) {
        let (dim, m) = (src.dim, src.lens[0]);
        self.layout(count, dim);
        let from = src.level(0);
        for k in 0..dim {
            self.data[k * count..(k + 1) * count].copy_from_slice(&from.component(k)[m - count..]);
        }
        self.coarsen();
    }

    /// Sizes the levels of an `n`-element sequence.
    fn layout(&mut self, n: usize, dim: usize) {
        self.dim = dim;
        self.lens.clear();
        self.starts.clear();
        let mut len = n;
        let mut total = 0;
        loop {
            self.lens.push(len);
            self.starts.push(total);
            total += len * dim;
            if len <= 1 {
                break;
            }
            len /= 2;
        }
        self.data.clear();
        self.data.resize(total, 0.0);
    }

    /// Computes levels `1..` from level 0.
    fn coarsen(&mut self) {
        let dim = self.dim;
        for l in 1..self.lens.len() {
            let (fine_len, len) = (self.lens[l - 1], self.lens[l]);
            let (head, tail) = self.data.split_at_mut(self.starts[l]);
            let fine = &head[self.starts[l - 1]..];
            for k in 0..dim {
                let src = &fine[k * fine_len..(k + 1) * fine_len];
                for (j, out) in tail[k * len..(k + 1) * len].iter_mut().enumerate() {
                    // `(x[i] + x[i + 1]) / 2` in float64, as the package computes it.
                    *out = (src[2 * j] + src[2 * j + 1]) / 2.0;
                }
            }
        }
    }

    /// Level `l` (`l < lens.len()`).
    #[inline]
    pub(crate) fn level(&self, l: usize) -> Level<'_> {
        let len = self.lens[l];
        let start = self.starts[l];
        Level { data: &self.data[start..start + len * self.dim], len }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_by_averaging_pairs_and_drops_an_odd_last_element() {
        // 5 elements of dimension 2: (0, 10), (1, 11), (2, 12), (3, 13), (4, 14).
        let seq: Vec<f32> = (0..5).flat_map(|j| [j as f32, 10.0 + j as f32]).collect();
        let p = Pyramid::new(&seq, 2);
        assert_eq!(p.lens, [5, 2, 1]);
        assert_eq!(p.level(0).component(1), &[10.0, 11.0, 12.0, 13.0, 14.0]);
        assert_eq!(p.level(1).component(0), &[0.5, 2.5]);
        assert_eq!(p.level(1).component(1), &[10.5, 12.5]);
        assert_eq!(p.level(2).component(0), &[1.5]);
    }
}
