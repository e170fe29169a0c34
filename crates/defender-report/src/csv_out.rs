//! The report as CSV: one row per task x algorithm x budget x strategy, with mean, std and
//! bootstrap-interval columns, for scripts.

use defender_rl::Budget;

use crate::stats::Estimate;
use crate::table::Table;

/// The CSV columns: mean and std (population, ddof = 0) over the row's `n_seeds` seeds;
/// `_ci_lo`/`_ci_hi` bound the 95% percentile bootstrap interval of the mean (`crate::bootstrap`).
/// Columns added after the first release go at the end, so that scripts reading by position
/// keep working; an empty field is a value the row does not have (the cost columns, from
/// `episode_cost_limit` on, are empty for a task without an episode cost limit: the crash tasks).
/// The shielded evaluation's columns (`shield_*`) are empty for a row without one (a bare row);
/// its cost, `shield_eval_cost_last10_*`, is given on the tasks with a cost limit, as the
/// evaluation cost is. `crashes_after_warmup_*` is empty for a row none of whose runs gives its
/// warm-up (a peer library's run). `filtered_*` counts the training episodes DEFENDER ended
/// over the run (empty for a row without a filter); the checked interventions' columns, from
/// `interventions_seeds` on, are empty for a row without `interventions.csv` (they are over the
/// `interventions_seeds` seeds that have it; `precision_*` empty when none was checked,
/// `lead_median_steps_*` when no continuation failed, `interventions_per_crash_avoided` without
/// a bare row or when the row does not crash less). The shares of evaluation episodes within the
/// limit, `eval_within_limit_last10_*` and `shield_eval_within_limit_last10_*` (0 to 1), are empty
/// for a task without a limit and for a row without `eval_episodes.csv` (the shielded one also
/// for a row without shielded episodes).
pub const CSV_HEADER: &str = "env,algo,budget_steps,budget_episodes,strategy,safe,unsafe,mode,num_demos,\
n_seeds,seeds,acc_reward_mean,acc_reward_std,crash_pct_mean,crash_pct_std,filtered_pct_mean,\
filtered_pct_std,time_pct_mean,time_pct_std,time_pct_seeds,wall_seconds_mean,wall_seconds_std,\
acc_reward_ci_lo,acc_reward_ci_hi,best_episode_mean,best_episode_std,best_episode_ci_lo,best_episode_ci_hi,\
last10_eval_mean,last10_eval_std,last10_eval_ci_lo,last10_eval_ci_hi,crash_pct_ci_lo,crash_pct_ci_hi,\
standing_pct_mean,standing_pct_std,standing_pct_ci_lo,standing_pct_ci_hi,\
crashes_mean,crashes_std,crashes_ci_lo,crashes_ci_hi,\
crashes_per_1k_env_steps_mean,crashes_per_1k_env_steps_std,crashes_per_1k_env_steps_ci_lo,crashes_per_1k_env_steps_ci_hi,\
episode_cost_limit,cost_rate_mean,cost_rate_std,cost_rate_ci_lo,cost_rate_ci_hi,\
eval_cost_last10_mean,eval_cost_last10_std,eval_cost_last10_ci_lo,eval_cost_last10_ci_hi,\
over_limit_mean,over_limit_std,over_limit_ci_lo,over_limit_ci_hi,\
over_limit_pct_mean,over_limit_pct_std,over_limit_pct_ci_lo,over_limit_pct_ci_hi,\
shield_eval_last10_mean,shield_eval_last10_std,shield_eval_last10_ci_lo,shield_eval_last10_ci_hi,\
shield_ended_pct_mean,shield_ended_pct_std,shield_ended_pct_ci_lo,shield_ended_pct_ci_hi,\
shield_eval_cost_last10_mean,shield_eval_cost_last10_std,shield_eval_cost_last10_ci_lo,shield_eval_cost_last10_ci_hi,\
crashes_after_warmup_mean,crashes_after_warmup_std,crashes_after_warmup_ci_lo,crashes_after_warmup_ci_hi,\
filtered_mean,filtered_std,filtered_ci_lo,filtered_ci_hi,interventions_seeds,\
checked_mean,checked_std,checked_ci_lo,checked_ci_hi,precision_mean,precision_std,precision_ci_lo,precision_ci_hi,\
lead_median_steps_mean,lead_median_steps_std,lead_median_steps_ci_lo,lead_median_steps_ci_hi,\
interventions_per_crash_avoided,\
eval_within_limit_last10_mean,eval_within_limit_last10_std,eval_within_limit_last10_ci_lo,eval_within_limit_last10_ci_hi,\
shield_eval_within_limit_last10_mean,shield_eval_within_limit_last10_std,shield_eval_within_limit_last10_ci_lo,\
shield_eval_within_limit_last10_ci_hi";

pub(crate) fn csv(table: &Table) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for row in &table.rows {
        let (steps, episodes) = match row.budget {
            Budget::Steps(n) => (n.to_string(), String::new()),
            Budget::Episodes(n) => (String::new(), n.to_string()),
        };
        let (strategy, safe, unsafe_, mode, demos) = match &row.filter {
            None => Default::default(),
            Some(f) => (
                f.strategy.clone(),
                f.safe().to_string(),
                f.unsafe_().to_string(),
                f.mode.to_string(),
                f.num_demos.map(|n| n.to_string()).unwrap_or_default(),
            ),
        };
        let seeds: Vec<String> = row.seeds.iter().map(u64::to_string).collect();
        let (time_mean, time_std, time_n) = row
            .time_pct
            .map_or((String::new(), String::new(), 0), |t| (t.mean.to_string(), t.std.to_string(), t.n));
        let fields = [
            row.env.clone(),
            row.algo.clone(),
            steps,
            episodes,
            strategy,
            safe,
            unsafe_,
            mode,
            demos,
            row.seeds.len().to_string(),
            seeds.join(";"),
            row.acc_reward.stat.mean.to_string(),
            row.acc_reward.stat.std.to_string(),
            row.crash_pct.stat.mean.to_string(),
            row.crash_pct.stat.std.to_string(),
            row.filtered_pct.mean.to_string(),
            row.filtered_pct.std.to_string(),
            time_mean,
            time_std,
            time_n.to_string(),
            row.wall_seconds.mean.to_string(),
            row.wall_seconds.std.to_string(),
        ];
        let mut fields: Vec<String> = fields.into_iter().collect();
        fields.extend(interval(Some(&row.acc_reward)));
        fields.extend(mean_std(row.best_episode.as_ref()));
        fields.extend(interval(row.best_episode.as_ref()));
        fields.extend(mean_std(Some(&row.last_evaluations)));
        fields.extend(interval(Some(&row.last_evaluations)));
        fields.extend(interval(Some(&row.crash_pct)));
        fields.extend(mean_std(row.standing_pct.as_ref()));
        fields.extend(interval(row.standing_pct.as_ref()));
        for e in [&row.crashes, &row.crashes_per_1k] {
            fields.extend(mean_std(Some(e)));
            fields.extend(interval(Some(e)));
        }
        let costs = row.costs.as_ref();
        fields.push(costs.map(|c| c.limit.to_string()).unwrap_or_default());
        for e in [
            costs.map(|c| &c.cost_rate),
            costs.and_then(|c| c.eval_cost.as_ref()),
            costs.map(|c| &c.over_limit),
            costs.map(|c| &c.over_limit_pct),
        ] {
            fields.extend(mean_std(e));
            fields.extend(interval(e));
        }
        let shield = row.shield.as_ref();
        for e in [
            shield.map(|s| &s.eval),
            shield.map(|s| &s.ended_pct),
            shield.filter(|_| costs.is_some()).map(|s| &s.cost),
        ] {
            fields.extend(mean_std(e));
            fields.extend(interval(e));
        }
        fields.extend(mean_std(row.crashes_after_warmup.as_ref()));
        fields.extend(interval(row.crashes_after_warmup.as_ref()));
        fields.extend(mean_std(row.filtered.as_ref()));
        fields.extend(interval(row.filtered.as_ref()));
        let checked = row.interventions.as_ref();
        fields.push(checked.map(|c| c.seeds.to_string()).unwrap_or_default());
        for e in [
            checked.map(|c| &c.checked),
            checked.and_then(|c| c.precision.as_ref()),
            checked.and_then(|c| c.lead.as_ref()),
        ] {
            fields.extend(mean_std(e));
            fields.extend(interval(e));
        }
        fields.push(checked.and_then(|c| c.per_crash_avoided).map(|v| v.to_string()).unwrap_or_default());
        for e in [
            costs.and_then(|c| c.eval_within_limit.as_ref()),
            costs.and_then(|c| c.shield_within_limit.as_ref()),
        ] {
            fields.extend(mean_std(e));
            fields.extend(interval(e));
        }
        let fields: Vec<String> = fields.into_iter().map(csv_field).collect();
        out.push_str(&fields.join(","));
        out.push('\n');
    }
    out
}

fn mean_std(estimate: Option<&Estimate>) -> [String; 2] {
    estimate.map_or_else(Default::default, |e| [e.stat.mean.to_string(), e.stat.std.to_string()])
}

fn interval(estimate: Option<&Estimate>) -> [String; 2] {
    estimate.map_or_else(Default::default, |e| [e.ci.lo.to_string(), e.ci.hi.to_string()])
}

/// Quotes a field that holds a comma, a quote or a newline (RFC 4180).
fn csv_field(text: String) -> String {
    if text.contains([',', '"', '\n']) { format!("\"{}\"", text.replace('"', "\"\"")) } else { text }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quotes() {
        assert_eq!(csv_field("a,b".into()), "\"a,b\"");
        assert_eq!(csv_field("ab".into()), "ab");
    }
}
