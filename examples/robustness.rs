//! Runs the robustness cases of `tests/common/robustness_cases.rs` (the table `tests/stiff.rs`
//! asserts) and prints, as a Markdown table, each case's figures, a naive routine's figures on the
//! same rays where one is kept for comparison, and whether its pass criterion holds. Exits with
//! status 1 if a case fails.
//!
//! `cargo run --release --example robustness`

#[path = "../tests/common/robustness_cases.rs"]
mod cases;

/// A table cell: pipes escaped.
fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

fn main() {
    println!("| case | setup | naive routine | raylume | pass criterion | result |");
    println!("|---|---|---|---|---|---|");
    let mut failed = Vec::new();
    for case in cases::CASES {
        let outcome = (case.run)();
        let result = if outcome.failures.is_empty() {
            "pass".to_owned()
        } else {
            failed.push(case.id);
            format!("**FAIL**: {}", outcome.failures.join("; "))
        };
        println!(
            "| {} {} | {} | {} | {} | {} | {} |",
            case.id,
            case.title,
            cell(case.setup),
            cell(outcome.naive.as_deref().unwrap_or("—")),
            cell(&outcome.figure),
            cell(case.criterion),
            cell(&result)
        );
    }
    eprintln!("{} of {} cases pass", cases::CASES.len() - failed.len(), cases::CASES.len());
    if !failed.is_empty() {
        eprintln!("failed: {}", failed.join(", "));
        std::process::exit(1);
    }
}
