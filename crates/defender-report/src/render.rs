//! The table as Markdown (for a terminal), LaTeX (booktabs, laid out like the paper's Tables 1
//! and 2) and CSV (one row per group, for scripts).

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::str::FromStr;

use defender::Mode;
use defender_rl::Budget;

use crate::run::DefenderSettings;
use crate::stats::Stat;
use crate::table::{Row, Table};

/// An output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Format {
    /// Markdown tables, one per trajectory mode and task, padded to read well in a terminal.
    #[default]
    Markdown,
    /// LaTeX tables (booktabs), one per trajectory mode, tasks side by side as in the paper.
    Latex,
    /// CSV: one row per task x algorithm x budget x strategy, mean and std columns.
    Csv,
}

impl FromStr for Format {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "md" | "markdown" => Ok(Format::Markdown),
            "latex" | "tex" => Ok(Format::Latex),
            "csv" => Ok(Format::Csv),
            _ => Err(format!("unknown format {s:?}: expected md, latex or csv")),
        }
    }
}

/// Renders `table` in `format`.
pub fn render(table: &Table, format: Format) -> String {
    match format {
        Format::Markdown => markdown(table),
        Format::Latex => latex(table),
        Format::Csv => csv(table),
    }
}

/// How a mean is printed: the paper prints Acc Reward and % Crash means without decimals and
/// their std with one; the Markdown table keeps one decimal on % Crash, which small runs need.
fn number(value: f64, decimals: usize) -> String {
    let text = format!("{value:.decimals$}");
    // `-0` and `-0.0` read as noise.
    if text.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        text.replace('-', "")
    } else {
        text
    }
}

fn pm(stat: &Stat, decimals: usize, sep: &str) -> String {
    format!("{}{sep}{}", number(stat.mean, decimals), number(stat.std, 1))
}

fn time(row: &Row) -> String {
    row.time_pct.map_or_else(|| "-".to_string(), |t| number(t.mean, 0))
}

fn mode_title(mode: Option<Mode>) -> &'static str {
    match mode {
        Some(Mode::State) => "state trajectories (as the paper's Table 1)",
        Some(Mode::StateAction) => "state-action trajectories (as the paper's Table 2)",
        None => "bare algorithms",
    }
}

/// The sections of a report: each trajectory mode (or just the bare rows when there is no
/// DEFENDER run), each with all bare rows.
fn sections(table: &Table) -> Vec<Option<Mode>> {
    let modes = table.modes();
    if modes.is_empty() { vec![None] } else { modes.into_iter().map(Some).collect() }
}

fn markdown(table: &Table) -> String {
    let demos = table.varies_num_demos();
    let mut out = String::from("# DEFENDER report\n");
    for mode in sections(table) {
        let _ = write!(out, "\n## {}\n", capitalise(mode_title(mode)));
        let columns: BTreeSet<(&str, Budget)> =
            table.rows_for(mode).map(|r| (r.env.as_str(), r.budget)).collect();
        for (env, budget) in columns {
            let _ = write!(out, "\n### {env}, {budget}\n\n");
            let mut header = vec!["Algorithm", "Safe", "Unsafe"];
            if demos {
                header.push("Demos");
            }
            header.extend(["Acc Reward", "% Crash", "% Time", "Seeds"]);
            let mut cells = vec![header.iter().map(|s| s.to_string()).collect::<Vec<_>>()];
            for row in table.rows_for(mode).filter(|r| r.env == env && r.budget == budget) {
                let (safe, unsafe_) = row
                    .filter
                    .as_ref()
                    .map_or(("-".to_string(), "-"), |f: &DefenderSettings| (f.safe_cell(), f.unsafe_()));
                let mut line = vec![row.algo.to_uppercase(), safe, unsafe_.to_string()];
                if demos {
                    line.push(demos_text(row));
                }
                line.extend([
                    pm(&row.acc_reward, 0, " ± "),
                    pm(&row.crash_pct, 1, " ± "),
                    time(row),
                    row.seeds.len().to_string(),
                ]);
                cells.push(line);
            }
            write_padded(&mut out, &cells, header.len() - 4);
        }
    }
    out.push_str(
        "\nAcc Reward: mean return of the final evaluation (10 deterministic episodes); % Crash: \
         crashed / all training episodes x 100; both mean ± std over seeds (population std, \
         ddof = 0). % Time: wall-clock time / that of the bare run with the same task, algorithm, \
         budget and seed x 100, averaged over seeds.\n",
    );
    if !table.notes.is_empty() {
        out.push_str("\nNotes:\n");
        for note in &table.notes {
            let _ = writeln!(out, "- {note}");
        }
    }
    out
}

fn demos_text(row: &Row) -> String {
    match &row.filter {
        None => "-".into(),
        Some(f) => f.num_demos.map_or_else(|| "?".into(), |n| n.to_string()),
    }
}

fn capitalise(text: &str) -> String {
    let mut chars = text.chars();
    chars.next().map(|c| c.to_uppercase().chain(chars).collect()).unwrap_or_default()
}

/// Writes a Markdown table with columns padded to equal width; the first `left` columns are
/// left-aligned, the others right-aligned.
fn write_padded(out: &mut String, cells: &[Vec<String>], left: usize) {
    let columns = cells.first().map_or(0, Vec::len);
    let widths: Vec<usize> =
        (0..columns).map(|c| cells.iter().map(|r| r[c].chars().count()).max().unwrap_or(0).max(3)).collect();
    for (i, row) in cells.iter().enumerate() {
        out.push('|');
        for (c, cell) in row.iter().enumerate() {
            let w = widths[c];
            if c < left {
                let _ = write!(out, " {cell:<w$} |");
            } else {
                let _ = write!(out, " {cell:>w$} |");
            }
        }
        out.push('\n');
        if i == 0 {
            out.push('|');
            for (c, w) in widths.iter().enumerate() {
                let dashes = "-".repeat(*w);
                if c < left {
                    let _ = write!(out, " {dashes} |");
                } else {
                    let _ = write!(out, " {}: |", &dashes[1..]);
                }
            }
            out.push('\n');
        }
    }
}

fn tex_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '%' | '&' | '_' | '#' | '$' | '{' | '}' => {
                out.push('\\');
                out.push(c);
            }
            '~' => out.push_str("\\textasciitilde{}"),
            '^' => out.push_str("\\textasciicircum{}"),
            '\\' => out.push_str("\\textbackslash{}"),
            _ => out.push(c),
        }
    }
    out
}

fn latex(table: &Table) -> String {
    let demos = table.varies_num_demos();
    let labels = if demos { 3 } else { 2 };
    let mut out =
        String::from("% defender report: needs \\usepackage{booktabs} and \\usepackage{graphicx}\n");
    for mode in sections(table) {
        let rows: Vec<&Row> = table.rows_for(mode).collect();
        // Columns: one group of three per (task, budget); the budget is named only when a task
        // has several.
        let columns: Vec<(&str, Budget)> =
            rows.iter().map(|r| (r.env.as_str(), r.budget)).collect::<BTreeSet<_>>().into_iter().collect();
        let column_title = |env: &str, budget: Budget| {
            if columns.iter().filter(|(e, _)| *e == env).count() > 1 {
                format!("{} ({budget})", tex_escape(env))
            } else {
                tex_escape(env)
            }
        };
        let _ = write!(
            out,
            "\n\\begin{{table}}[tb]\n\\caption{{Performance, safety and computation time, {}.}}\n\
             \\centering\n\\resizebox{{\\textwidth}}{{!}}{{%\n\\begin{{tabular}}{{{}{}}}\n\\toprule\n",
            tex_escape(mode_title(mode)),
            "l".repeat(labels),
            "rrr".repeat(columns.len())
        );
        out.push_str(&" & ".repeat(labels - 1));
        for (env, budget) in &columns {
            let _ = write!(out, " & \\multicolumn{{3}}{{c}}{{{}}}", column_title(env, *budget));
        }
        out.push_str(" \\\\\n");
        for i in 0..columns.len() {
            let first = labels + 1 + 3 * i;
            let _ = write!(out, "\\cmidrule(lr){{{first}-{}}} ", first + 2);
        }
        out.push_str(if demos { "\nSafe & Unsafe & Demos" } else { "\nSafe & Unsafe" });
        for _ in &columns {
            out.push_str(" & Acc Reward & \\% Crash & \\% Time");
        }
        out.push_str(" \\\\\n");
        let algos: Vec<&str> =
            rows.iter().map(|r| r.algo.as_str()).collect::<BTreeSet<_>>().into_iter().collect();
        for algo in algos {
            out.push_str("\\midrule\n");
            let filters: Vec<Option<&DefenderSettings>> = rows
                .iter()
                .filter(|r| r.algo == algo)
                .map(|r| r.filter.as_ref())
                .collect::<BTreeSet<_>>()
                .into_iter()
                .collect();
            for filter in filters {
                match filter {
                    None => {
                        let _ = write!(
                            out,
                            "\\multicolumn{{{labels}}}{{l}}{{{}}}",
                            tex_escape(&algo.to_uppercase())
                        );
                    }
                    Some(f) => {
                        let _ = write!(out, "{} & {}", tex_escape(&f.safe_cell()), tex_escape(f.unsafe_()));
                        if demos {
                            let _ = write!(out, " & {}", f.num_demos.map_or("?".into(), |n| n.to_string()));
                        }
                    }
                }
                for (env, budget) in &columns {
                    let cell = rows.iter().find(|r| {
                        r.algo == algo && r.env == *env && r.budget == *budget && r.filter.as_ref() == filter
                    });
                    match cell {
                        Some(r) => {
                            let _ = write!(
                                out,
                                " & {} & {} & {}",
                                pm(&r.acc_reward, 0, "$\\pm$"),
                                pm(&r.crash_pct, 0, "$\\pm$"),
                                time(r)
                            );
                        }
                        None => out.push_str(" & - & - & -"),
                    }
                }
                out.push_str(" \\\\\n");
                if filter.is_none() {
                    out.push_str("\\cmidrule(lr){1-");
                    let _ = writeln!(out, "{}}}", labels + 3 * columns.len());
                }
            }
        }
        out.push_str("\\bottomrule\n\\end{tabular}}\n\\end{table}\n");
    }
    for note in &table.notes {
        let _ = writeln!(out, "% Note: {note}");
    }
    out
}

/// The CSV columns.
pub const CSV_HEADER: &str = "env,algo,budget_steps,budget_episodes,strategy,safe,unsafe,mode,num_demos,\
n_seeds,seeds,acc_reward_mean,acc_reward_std,crash_pct_mean,crash_pct_std,filtered_pct_mean,\
filtered_pct_std,time_pct_mean,time_pct_std,time_pct_seeds,wall_seconds_mean,wall_seconds_std";

fn csv(table: &Table) -> String {
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
            row.acc_reward.mean.to_string(),
            row.acc_reward.std.to_string(),
            row.crash_pct.mean.to_string(),
            row.crash_pct.std.to_string(),
            row.filtered_pct.mean.to_string(),
            row.filtered_pct.std.to_string(),
            time_mean,
            time_std,
            time_n.to_string(),
            row.wall_seconds.mean.to_string(),
            row.wall_seconds.std.to_string(),
        ];
        let fields: Vec<String> = fields.into_iter().map(csv_field).collect();
        out.push_str(&fields.join(","));
        out.push('\n');
    }
    out
}

/// Quotes a field that holds a comma, a quote or a newline (RFC 4180).
fn csv_field(text: String) -> String {
    if text.contains([',', '"', '\n']) { format!("\"{}\"", text.replace('"', "\"\"")) } else { text }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_round_like_the_paper() {
        assert_eq!(number(3474.4, 0), "3474");
        assert_eq!(number(-0.3, 0), "0");
        assert_eq!(number(-0.04, 1), "0.0");
        assert_eq!(number(-4.0, 0), "-4");
        let s = Stat { mean: 63.96, std: 6.04, n: 3 };
        assert_eq!(pm(&s, 0, "$\\pm$"), "64$\\pm$6.0");
    }

    #[test]
    fn escapes_and_quotes() {
        assert_eq!(tex_escape("a_b 50% & c"), "a\\_b 50\\% \\& c");
        assert_eq!(csv_field("a,b".into()), "\"a,b\"");
        assert_eq!(csv_field("ab".into()), "ab");
        assert_eq!("latex".parse::<Format>(), Ok(Format::Latex));
        assert!("html".parse::<Format>().is_err());
    }
}
