//! Times batch DTW and one streaming push, for `tools/peers/dtw_bench_peer.py` (which runs dtaidistance
//! beside it) and for quick checks.
//!
//! ```sh
//! cargo run --release -p defender-dtw --example dtw_speed -- batch 1000 1000 11 [x.f32 y.f32]
//! cargo run --release -p defender-dtw --example dtw_speed -- push 100 1000 11
//! cargo run --release -p defender-dtw --example dtw_speed -- step 100 1000 11
//! ```
//! `step` times one filter step of the authors' profile: the last 20 elements of a trajectory
//! against every reference, FastDTW (radius 1, L1) and exact DTW (L2, L1); per step, CPU time,
//! min / median / max of 7 rounds of 100 steps.
//! `batch` prints `cost=<dtw> seconds=<best of runs> cells_per_s=<n*m/seconds>`; the optional
//! files are raw little-endian f32, row-major (else random walks are used).

use std::time::Instant;

use defender_dtw::{Dtw, FastDtw, FastReferences, Metric, QueryWindow, RefWindow, References, View, dtw};

#[path = "../benches/support/walk.rs"]
mod walk;
use walk::walk;

/// CPU time of this thread: the machine is shared, so wall time would count other processes.
fn cpu_seconds() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec for the duration of the call.
    unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

fn read_f32(path: &str) -> anyhow_free::Result<Vec<f32>> {
    let bytes = std::fs::read(path)?;
    Ok(bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect())
}

mod anyhow_free {
    pub type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;
}

fn main() -> anyhow_free::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: usize| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(default);
    match args.first().map(String::as_str) {
        Some("batch") => {
            let (n, m, dim) = (arg(1, 1000), arg(2, 1000), arg(3, 11));
            let (x, y) = match (args.get(4), args.get(5)) {
                (Some(a), Some(b)) => (read_f32(a)?, read_f32(b)?),
                _ => (walk(n, dim, 1), walk(m, dim, 2)),
            };
            let (n, m) = (x.len() / dim, y.len() / dim);
            let (mut best, mut best_cpu) = (f64::INFINITY, f64::INFINITY);
            let mut cost = 0.0;
            for _ in 0..20 {
                let (t, c) = (Instant::now(), cpu_seconds());
                cost = dtw(&x, &y, dim, &Dtw::euclidean())?;
                best_cpu = best_cpu.min(cpu_seconds() - c);
                best = best.min(t.elapsed().as_secs_f64());
            }
            let cells = (n * m) as f64;
            println!(
                "cost={cost} seconds={best:.6e} cells_per_s={:.4e} cpu_seconds={best_cpu:.6e} cpu_cells_per_s={:.4e}",
                cells / best,
                cells / best_cpu
            );
        }
        Some("push") => {
            let (count, m, dim) = (arg(1, 100), arg(2, 1000), arg(3, 11));
            let seqs: Vec<Vec<f32>> = (0..count).map(|i| walk(m, dim, 10 + i as u64)).collect();
            let slices: Vec<&[f32]> = seqs.iter().map(Vec::as_slice).collect();
            let refs = References::new(dim, &slices)?;
            let query = walk(m, dim, 3);
            let sets: [(&str, Vec<View>); 3] = [
                ("(All,All)", vec![View::new(QueryWindow::All, RefWindow::All)]),
                (
                    "(All,All)+(Last(10),All)",
                    vec![
                        View::new(QueryWindow::All, RefWindow::All),
                        View::new(QueryWindow::Last(10), RefWindow::All),
                    ],
                ),
                (
                    "(All,Last(5))+(All,Last(10))+(Last(5),Last(5))",
                    vec![
                        View::new(QueryWindow::All, RefWindow::Last(5)),
                        View::new(QueryWindow::All, RefWindow::Last(10)),
                        View::new(QueryWindow::Last(5), RefWindow::Last(5)),
                    ],
                ),
            ];
            for (name, views) in sets {
                let mut stream = refs.stream(&views)?;
                let (mut best, mut best_cpu) = (f64::INFINITY, f64::INFINITY);
                // Best of 3 episodes of m pushes.
                for _ in 0..3 {
                    stream.reset();
                    let (t, c) = (Instant::now(), cpu_seconds());
                    for xt in query.chunks_exact(dim) {
                        stream.push(xt)?;
                    }
                    best_cpu = best_cpu.min((cpu_seconds() - c) / m as f64);
                    best = best.min(t.elapsed().as_secs_f64() / m as f64);
                }
                println!(
                    "{name}: {count} refs x {m} x d={dim}: {:.2} us per push (cpu {:.2} us)",
                    best * 1e6,
                    best_cpu * 1e6
                );
            }
        }
        Some("step") => {
            let (count, m, dim) = (arg(1, 100), arg(2, 1000), arg(3, 11));
            let seqs: Vec<Vec<f32>> = (0..count).map(|i| walk(m, dim, 200 + i as u64)).collect();
            let slices: Vec<&[f32]> = seqs.iter().map(Vec::as_slice).collect();
            let trajectory = walk(120, dim, 4);
            let all = View::new(QueryWindow::All, RefWindow::All);
            let mut fast = FastReferences::new(dim, &slices, FastDtw::default())?;
            let exact = References::new(dim, &slices)?;
            let (mut out64, mut out32) = (vec![0.0; count], vec![0.0; count]);
            let l1 = Dtw::euclidean().with_metric(Metric::L1);
            let run = |name: &str, step: &mut dyn FnMut(&[f32]) -> defender_dtw::Result<()>| {
                let mut rounds = Vec::new();
                for _ in 0..7 {
                    let c = cpu_seconds();
                    for t in 0..100 {
                        step(&trajectory[t * dim..(t + 20) * dim])?;
                    }
                    rounds.push((cpu_seconds() - c) / 100.0 * 1e6);
                }
                rounds.sort_by(f64::total_cmp);
                println!(
                    "{name}: 20 x {m} x d={dim}, {count} refs: {:.1} us per step (cpu; min {:.1}, max {:.1})",
                    rounds[3], rounds[0], rounds[6]
                );
                defender_dtw::Result::Ok(())
            };
            run("fastdtw r1 l1", &mut |q| fast.costs_into(q, &all, &mut out64))?;
            run("exact l2", &mut |q| exact.align_view_into(q, &all, &Dtw::euclidean(), &mut out32))?;
            run("exact l1", &mut |q| exact.align_view_into(q, &all, &l1, &mut out32))?;
        }
        _ => eprintln!("usage: dtw_speed batch N M D [x.f32 y.f32] | push REFS M D | step REFS M D"),
    }
    Ok(())
}
