//! Once warm, FastDTW against prepared references allocates nothing per call: every step of an
//! authors-profile episode calls it (one query against every demonstration).
#![allow(clippy::unwrap_used)]

use defender_dtw::{FastDtw, FastReferences, Metric, QueryWindow, RefWindow, View};

#[global_allocator]
static GLOBAL: alloc_counter::Counting = alloc_counter::Counting;

fn walk(len: usize, dim: usize, seed: u32) -> Vec<f32> {
    let mut state = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
    let mut pos = vec![0.0f32; dim];
    let mut out = Vec::with_capacity(len * dim);
    for _ in 0..len {
        for p in &mut pos {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            *p += (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
            out.push(*p);
        }
    }
    out
}

#[test]
fn costs_into_allocates_nothing_once_warm() {
    let dim = 11;
    let seqs: Vec<Vec<f32>> = (0..12).map(|i| walk(5 + 97 * i, dim, i as u32)).collect();
    let slices: Vec<&[f32]> = seqs.iter().map(Vec::as_slice).collect();
    let trajectory = walk(80, dim, 99);
    let views = [
        View::new(QueryWindow::All, RefWindow::All),
        View::new(QueryWindow::All, RefWindow::MatchQuery),
        View::new(QueryWindow::Last(5), RefWindow::Last(10)),
    ];
    for settings in [FastDtw::default(), FastDtw::new(2, Metric::L2)] {
        let mut refs = FastReferences::new(dim, &slices, settings).unwrap();
        let mut out = vec![0.0; refs.len()];
        // Warm-up: the longest query (20 elements, the trajectory cap) and every view.
        for view in &views {
            refs.costs_into(&trajectory[..20 * dim], view, &mut out).unwrap();
        }
        let before = alloc_counter::allocations();
        for t in 1..60_usize {
            let start = t.saturating_sub(20);
            for view in &views {
                refs.costs_into(&trajectory[start * dim..t * dim], view, &mut out).unwrap();
            }
        }
        assert_eq!(alloc_counter::allocations() - before, 0, "{settings:?}");
        assert!(out.iter().all(|c| c.is_finite()));
    }
}
