//! The closing line of a DEFENDER run about its interventions: the episodes it ended beside
//! the crashes (the half of the story a crash percentage leaves out), and, where they were
//! checked, how many would have failed and how far ahead (docs/SPEC.md, section 15).

use defender_report::{InterventionRow, InterventionSummary};
use defender_rl::{EpisodeRecord, InterventionRecord, Outcome};

/// `interventions: ...` for a run's episodes and interventions.
pub fn line(episodes: &[EpisodeRecord], interventions: &[InterventionRecord]) -> String {
    let crashes = episodes.iter().filter(|e| e.outcome() == Outcome::Crashed).count();
    let rows: Vec<InterventionRow> = interventions
        .iter()
        .map(|r| InterventionRow {
            total_steps: r.total_steps,
            checked: r.checked,
            would_fail: r.would_fail,
            steps_to_failure: r.steps_to_failure,
        })
        .collect();
    let s = InterventionSummary::of(&rows, 0);
    let mut text = format!(
        "interventions: {} episodes ended before their action ran, beside {crashes} crashes",
        s.interventions
    );
    if let Some(p) = s.precision() {
        let lead = s.median_lead.map_or(String::new(), |l| format!(", a median {l:.0} steps ahead"));
        text.push_str(&format!(
            "; checked {}: {} would have failed unfiltered (precision {p:.2}){lead}",
            s.checked, s.would_fail
        ));
    }
    text
}
