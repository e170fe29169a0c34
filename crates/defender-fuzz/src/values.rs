//! Experiment files whose syntax is right and whose values are the fuzzer's: every number of
//! `[run]` (the top-level keys, `[sac]`, `[td3]`, `[defender]`, `[defender.cost]`,
//! `[defender.dynamics]`), the grid's lists and the budget, so that the checks behind the parser
//! (`RunConfig::validate` and the expansion) see every value, not only the ones a mutated file
//! happens to spell.
//!
//! The input is read as a stream of choices ([`arbitrary::Unstructured`]): for each key of the
//! defaults, keep it, drop it, or give it an arbitrary or an edge value of its type.

use arbitrary::{Result, Unstructured};
use toml::{Table, Value};

use crate::experiment::TASKS;

const STRATEGIES: [&str; 5] =
    ["none", "auto", "MeanDemoW5/MeanDemoW10", "MinBoth/MinBoth", "MaxDemo/MeanBothW3"];
const MODES: [&str; 2] = ["state", "state-action"];
const ALGOS: [&str; 2] = ["sac", "td3"];

const EDGE_INTEGERS: [i64; 10] = [0, 1, -1, 2, 255, 1 << 31, 1 << 32, 1 << 53, i64::MAX, i64::MIN];
const EDGE_FLOATS: [f64; 12] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::MAX,
    f64::MIN_POSITIVE,
    5e-324,
    1e-9,
    1e9,
];

fn integer(u: &mut Unstructured<'_>) -> Result<i64> {
    if u.arbitrary()? { Ok(*u.choose(&EDGE_INTEGERS)?) } else { u.arbitrary() }
}

fn float(u: &mut Unstructured<'_>) -> Result<f64> {
    if u.arbitrary()? { Ok(*u.choose(&EDGE_FLOATS)?) } else { u.arbitrary() }
}

/// A value of `like`'s type.
fn value_like(u: &mut Unstructured<'_>, like: &Value) -> Result<Value> {
    Ok(match like {
        Value::Integer(_) => Value::Integer(integer(u)?),
        Value::Float(_) => Value::Float(float(u)?),
        Value::Boolean(_) => Value::Boolean(u.arbitrary()?),
        Value::String(s) => {
            // The spelling of an option (an enum's name, "auto"): its own, or another one.
            if u.arbitrary()? {
                Value::String(u.arbitrary::<String>()?.chars().take(24).collect())
            } else {
                Value::String(s.clone())
            }
        }
        Value::Array(items) => {
            let n = u.int_in_range(0..=4)?;
            let like = items.first().cloned().unwrap_or(Value::Integer(0));
            Value::Array((0..n).map(|_| value_like(u, &like)).collect::<Result<_>>()?)
        }
        other => other.clone(),
    })
}

/// `table` with each key kept, dropped or given another value, as the input chooses.
fn vary(u: &mut Unstructured<'_>, table: &Table) -> Result<Table> {
    let mut out = Table::new();
    for (key, value) in table {
        let varied = match value {
            Value::Table(inner) => Some(Value::Table(vary(u, inner)?)),
            _ => match u.int_in_range(0..=3)? {
                0 | 1 => Some(value.clone()),
                2 => Some(value_like(u, value)?),
                _ => None,
            },
        };
        if let Some(v) = varied {
            out.insert(key.clone(), v);
        }
    }
    Ok(out)
}

fn table_of<T: serde::Serialize>(value: &T) -> Table {
    match Value::try_from(value) {
        Ok(Value::Table(t)) => t,
        _ => Table::new(),
    }
}

/// Every setting of `[run]` at its default: what the input varies.
fn defaults() -> Table {
    let mut run = Table::new();
    run.insert("eval_freq".into(), Value::Integer(0));
    run.insert("eval_episodes".into(), Value::Integer(5));
    run.insert("checkpoint_every_episodes".into(), Value::Integer(0));
    run.insert("checkpoint_every_seconds".into(), Value::Integer(120));
    run.insert("sac".into(), Value::Table(table_of(&defender_rl::SacConfig::default())));
    run.insert("td3".into(), Value::Table(table_of(&defender_rl::Td3Config::default())));
    let mut defender = Table::new();
    defender.insert("r_task".into(), Value::Float(-1.0));
    defender.insert("num_demos".into(), Value::Integer(50));
    let cost = defender_config::run_config::CostSection::default();
    defender.insert("cost".into(), Value::Table(table_of(&cost)));
    defender.insert("dynamics".into(), Value::Table(table_of(&defender::DynamicsConfig::default())));
    run.insert("defender".into(), Value::Table(defender));
    run
}

/// A non-empty selection of `items`, in order.
fn some_of(u: &mut Unstructured<'_>, items: &[&str]) -> Result<Value> {
    let mut chosen: Vec<Value> =
        items.iter().filter(|_| u.arbitrary::<bool>().unwrap_or(false)).map(|s| Value::from(*s)).collect();
    if chosen.is_empty() {
        chosen.push(Value::from(*u.choose(items)?));
    }
    Ok(Value::Array(chosen))
}

fn integers(u: &mut Unstructured<'_>, at_least: usize) -> Result<Value> {
    let n = u.int_in_range(at_least..=3)?;
    Ok(Value::Array((0..n).map(|_| integer(u).map(Value::Integer)).collect::<Result<_>>()?))
}

/// The experiment file the input describes.
pub fn values_file(u: &mut Unstructured<'_>) -> Result<String> {
    let mut grid = Table::new();
    grid.insert("envs".into(), some_of(u, TASKS)?);
    grid.insert("algos".into(), some_of(u, &ALGOS)?);
    grid.insert("strategies".into(), some_of(u, &STRATEGIES)?);
    grid.insert("modes".into(), some_of(u, &MODES)?);
    if u.arbitrary()? {
        grid.insert("num_demos".into(), integers(u, 0)?);
    }
    grid.insert("seeds".into(), integers(u, 1)?);
    let mut budget = Table::new();
    let key = if u.arbitrary()? { "episodes" } else { "steps" };
    // 1000 unless the input gives another (an all-zero input is then a valid experiment).
    let total = if u.arbitrary()? { integer(u)? } else { 1000 };
    budget.insert(key.into(), Value::Integer(total));
    if u.arbitrary()? {
        let mut own = Table::new();
        own.insert(key.into(), Value::Integer(integer(u)?));
        own.insert("eval_freq".into(), Value::Integer(integer(u)?));
        let mut per_env = Table::new();
        per_env.insert((*u.choose(TASKS)?).into(), Value::Table(own));
        budget.insert("per_env".into(), Value::Table(per_env));
    }
    let mut file = Table::new();
    file.insert("grid".into(), Value::Table(grid));
    file.insert("budget".into(), Value::Table(budget));
    file.insert("run".into(), Value::Table(vary(u, &defaults())?));
    Ok(toml::to_string(&file).unwrap_or_default())
}

/// An experiment file of valid syntax made from the input's values, parsed and expanded with
/// every run checked.
pub fn experiment_values(data: &[u8]) -> bool {
    let mut u = Unstructured::new(data);
    let Ok(text) = values_file(&mut u) else { return false };
    crate::experiment(text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_make_a_valid_experiment_and_edge_values_are_refused() {
        // All zeros: every key kept at its default, one task, one algorithm, one seed.
        let text = values_file(&mut Unstructured::new(&[0u8; 64])).unwrap();
        defender_config::experiment::parse(&text, TASKS).unwrap_or_else(|e| panic!("{e:#}\n{text}"));
        let text = values_file(&mut Unstructured::new(&[0xffu8; 4096])).unwrap();
        assert!(defender_config::experiment::parse(&text, TASKS).is_err(), "{text}");
    }
}
