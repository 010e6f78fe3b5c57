//! Row-compressed sparse matrices for the lightfield resampling operators (each output sample
//! averages a few supersampled, interpolated reads: tens of distinct inputs per row).
//!
//! Rows are built independently (in parallel, fixed chunks, concatenated in index order) and
//! their entries merged and sorted by column, so the matrix does not depend on the thread
//! count; products run over rows, each a fixed-order sum.

use rayon::prelude::*;

/// Rows per parallel chunk.
const CHUNK: usize = 256;

/// A CSR matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct Csr {
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// Row `i`'s entries are `ptr[i]..ptr[i+1]`.
    pub ptr: Vec<usize>,
    /// Column indices, ascending within a row.
    pub idx: Vec<u32>,
    /// Values.
    pub val: Vec<f64>,
}

impl Csr {
    /// Builds `rows × cols` from a row generator that pushes `(column, value)` pairs
    /// (duplicates are summed; zero values dropped).
    pub fn build(rows: usize, cols: usize, row: impl Fn(usize, &mut Vec<(u32, f64)>) + Sync) -> Self {
        let chunks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = (0..rows.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut lens = Vec::with_capacity(CHUNK);
                let mut idx = Vec::new();
                let mut val = Vec::new();
                let mut buf = Vec::new();
                for i in c * CHUNK..((c + 1) * CHUNK).min(rows) {
                    buf.clear();
                    row(i, &mut buf);
                    buf.sort_unstable_by_key(|e| e.0);
                    let start = idx.len();
                    for &(j, v) in buf.iter() {
                        if idx.len() > start && *idx.last().unwrap_or(&u32::MAX) == j {
                            if let Some(last) = val.last_mut() {
                                *last += v;
                            }
                        } else {
                            idx.push(j);
                            val.push(v);
                        }
                    }
                    // drop exact zeros (sums that cancel included; sorted order is kept)
                    let mut w = start;
                    for r in start..idx.len() {
                        if val[r] != 0.0 {
                            idx[w] = idx[r];
                            val[w] = val[r];
                            w += 1;
                        }
                    }
                    idx.truncate(w);
                    val.truncate(w);
                    lens.push(idx.len() - start);
                }
                (lens, idx, val)
            })
            .collect();
        // concatenated at their exact size (the propagation resamplings hold ~0.9M entries)
        let nnz: usize = chunks.iter().map(|c| c.1.len()).sum();
        let mut ptr = Vec::with_capacity(rows + 1);
        ptr.push(0);
        let (mut idx, mut val) = (Vec::with_capacity(nnz), Vec::with_capacity(nnz));
        for (lens, i, v) in chunks {
            for l in lens {
                ptr.push(ptr.last().copied().unwrap_or(0) + l);
            }
            idx.extend(i);
            val.extend(v);
        }
        Self { rows, cols, ptr, idx, val }
    }

    /// Stored entries.
    pub fn nnz(&self) -> usize {
        self.idx.len()
    }

    /// `A·X` for `X` (`cols × k`, row-major): `rows × k`, row-major.
    pub fn apply(&self, x: &[f64], k: usize) -> Vec<f64> {
        assert_eq!(x.len(), self.cols * k);
        let mut out = vec![0.0; self.rows * k];
        if k == 0 {
            return out;
        }
        out.par_chunks_mut(k * CHUNK).enumerate().for_each(|(c, block)| {
            for (q, dst) in block.chunks_mut(k).enumerate() {
                let i = c * CHUNK + q;
                for e in self.ptr[i]..self.ptr[i + 1] {
                    let w = self.val[e];
                    let src = &x[self.idx[e] as usize * k..(self.idx[e] as usize + 1) * k];
                    for (d, s) in dst.iter_mut().zip(src) {
                        *d += w * s;
                    }
                }
            }
        });
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merges_duplicates_and_multiplies() {
        let a = Csr::build(3, 4, |i, v| {
            v.push((3, 1.0));
            v.push((i as u32, 2.0));
            v.push((3, 0.5));
            if i == 2 {
                v.push((0, 0.0));
            }
        });
        assert_eq!(a.ptr, vec![0, 2, 4, 6]);
        assert_eq!(a.idx, vec![0, 3, 1, 3, 2, 3]);
        assert_eq!(a.val, vec![2.0, 1.5, 2.0, 1.5, 2.0, 1.5]);
        let x = [1.0, 10.0, 2.0, 20.0, 3.0, 30.0, 4.0, 40.0];
        let y = a.apply(&x, 2);
        assert_eq!(y, vec![2.0 + 6.0, 20.0 + 60.0, 4.0 + 6.0, 40.0 + 60.0, 6.0 + 6.0, 60.0 + 60.0]);
    }
}
