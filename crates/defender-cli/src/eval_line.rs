//! The evaluation line of `defender train`'s closing summary: the mean of the last
//! [`LAST_EVALUATIONS`] evaluations (the report's "last-10" figure; one evaluation alone is
//! noisy), their cost (on a crash task, where the cost is the crash, the share of episodes that
//! crashed), and for a run with a filter the same episodes with
//! the filter kept, so the two halves of a DEFENDER run (the policy alone, the policy with its
//! shield) show at the end of every run and not only in `defender report`.

use defender_report::LAST_EVALUATIONS;
use defender_rl::EvalRecord;

/// `None` before the first evaluation. `cost_limit`: the task's episode cost limit (a cost task),
/// `None` on a crash task.
pub fn eval_line(evals: &[EvalRecord], cost_limit: Option<f64>) -> Option<String> {
    let last = &evals[evals.len().saturating_sub(LAST_EVALUATIONS)..];
    if last.is_empty() {
        return None;
    }
    let mean = |f: &dyn Fn(&EvalRecord) -> Option<f64>| -> Option<f64> {
        let values: Option<Vec<f64>> = last.iter().map(f).collect();
        values.map(|v| v.iter().sum::<f64>() / v.len() as f64)
    };
    let what = if last.len() == 1 {
        "the last evaluation".to_string()
    } else {
        format!("mean of the last {}", last.len())
    };
    let mut line = format!(
        "evaluation ({what} of {}): return {:.1}",
        evals.len(),
        mean(&|r| Some(r.mean_return)).unwrap_or(f64::NAN)
    );
    let cost = |c: f64| match cost_limit {
        Some(limit) => format!("cost {c:.1} (limit {limit})"),
        None => format!("crashed {:.0}%", 100.0 * c),
    };
    if let Some(c) = mean(&|r| r.mean_cost) {
        line += &format!(", {}", cost(c));
    }
    let shield = |f: fn(&defender_rl::ShieldedEval) -> f64| mean(&|r: &EvalRecord| r.shield.as_ref().map(f));
    if let (Some(ret), Some(c), Some(ended)) =
        (shield(|s| s.mean_return), shield(|s| s.mean_cost), shield(|s| s.filtered))
    {
        line += &format!(
            "; with the filter kept: return {ret:.1}, {}, {:.0}% of episodes ended by it",
            cost(c),
            100.0 * ended
        );
    }
    Some(line)
}

#[cfg(test)]
mod tests {
    use defender_rl::ShieldedEval;

    use super::*;

    fn record(step: u64, ret: f64, cost: Option<f64>, shield: Option<(f64, f64, f64)>) -> EvalRecord {
        EvalRecord {
            total_steps: step,
            mean_return: ret,
            std_return: 0.0,
            mean_length: 10.0,
            mean_cost: cost,
            episodes: 5,
            returns: vec![ret; 5],
            costs: Vec::new(),
            is_final: false,
            shield: shield.map(|(r, c, f)| ShieldedEval {
                mean_return: r,
                std_return: 0.0,
                mean_length: 10.0,
                mean_cost: c,
                filtered: f,
                returns: vec![r; 5],
                costs: Vec::new(),
                stopped: Vec::new(),
            }),
        }
    }

    #[test]
    fn no_line_before_the_first_evaluation() {
        assert_eq!(eval_line(&[], None), None);
    }

    #[test]
    fn the_mean_of_the_last_ten_with_and_without_the_filter() {
        // Twelve evaluations: the first two (return 1000) are outside the last ten.
        let evals: Vec<EvalRecord> = (0..12u32)
            .map(|i| {
                let late = i >= 2;
                let (ret, cost) = if late { (100.0 + f64::from(i), 30.0) } else { (1000.0, 0.0) };
                record(
                    u64::from(i) * 1000,
                    ret,
                    Some(cost),
                    Some((50.0, 5.0, if i % 2 == 0 { 0.2 } else { 0.4 })),
                )
            })
            .collect();
        assert_eq!(
            eval_line(&evals, Some(25.0)).unwrap(),
            "evaluation (mean of the last 10 of 12): return 106.5, cost 30.0 (limit 25); \
             with the filter kept: return 50.0, cost 5.0 (limit 25), 30% of episodes ended by it"
        );
    }

    #[test]
    fn a_run_without_a_filter_or_costs_shows_the_return_alone() {
        let evals = [record(1000, 12.0, None, None)];
        assert_eq!(eval_line(&evals, None).unwrap(), "evaluation (the last evaluation of 1): return 12.0");
    }

    #[test]
    fn a_crash_tasks_cost_is_the_share_of_episodes_that_crashed() {
        let evals = [record(1000, 12.0, Some(0.8), Some((10.0, 0.0, 0.6)))];
        assert_eq!(
            eval_line(&evals, None).unwrap(),
            "evaluation (the last evaluation of 1): return 12.0, crashed 80%; \
             with the filter kept: return 10.0, crashed 0%, 60% of episodes ended by it"
        );
    }
}
