//! "Did you mean …?" for misspelt names (component types, parameters,
//! subsystem files): the known names closest to what was written by edit
//! distance (Levenshtein, 1966), compared without regard to case.

/// Edit distance between `a` and `b`: insertions, deletions and substitutions.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.to_lowercase().chars().collect();
    let b: Vec<char> = b.to_lowercase().chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let above = row[j + 1];
            row[j + 1] = (above + 1).min(row[j] + 1).min(diagonal + usize::from(ca != cb));
            diagonal = above;
        }
    }
    row[b.len()]
}

/// The known names nearest to `written` (at most three, best first), when
/// they are near enough to be a slip: at most a third of the longer name's
/// letters differ (at least one).
pub fn nearest<'a>(written: &str, known: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    let mut scored: Vec<(usize, &str)> = known
        .into_iter()
        .filter(|k| *k != written)
        .map(|k| (edit_distance(written, k), k))
        .filter(|(d, k)| *d <= (written.chars().count().max(k.chars().count()) / 3).max(1))
        .collect();
    scored.sort();
    scored.dedup();
    scored.into_iter().take(3).map(|(_, k)| k).collect()
}

/// `; did you mean "x"?` (or `"x" or "y"`) for a misspelt name, or "" when nothing is near.
pub fn did_you_mean<'a>(written: &str, known: impl IntoIterator<Item = &'a str>) -> String {
    let near = nearest(written, known);
    if near.is_empty() {
        return String::new();
    }
    let quoted: Vec<String> = near.iter().map(|n| format!("\"{n}\"")).collect();
    format!("; did you mean {}?", quoted.join(" or "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_counts_edits() {
        assert_eq!(edit_distance("chamber", "chamber"), 0);
        assert_eq!(edit_distance("chamer", "chamber"), 1);
        assert_eq!(edit_distance("dead_volme", "dead_volume"), 1);
        assert_eq!(edit_distance("valve52", "valve_5_2"), 2);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("Chamber", "chamber"), 0);
    }

    #[test]
    fn only_near_names_are_suggested() {
        let known = ["chamber", "check_valve", "conductance", "cylinder"];
        assert_eq!(nearest("chamer", known), vec!["chamber"]);
        assert_eq!(did_you_mean("cylnder", known), "; did you mean \"cylinder\"?");
        assert_eq!(did_you_mean("spring_damper", known), "");
        assert_eq!(nearest("pp", ["p", "T"]), vec!["p"]);
    }
}
