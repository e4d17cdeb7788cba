//! Warnings that repeat line after line (a material warned about at each of
//! its thousand uses) folded into one line with a count.

/// `warnings` with each message that differs only in its `file:line: `
/// prefix given once, at its first place and with its first line, and a
/// count of the other lines. Other warnings keep their order and text.
pub fn fold_repeated(warnings: &[String]) -> Vec<String> {
    let mut order: Vec<(String, &str, usize)> = Vec::new();
    for w in warnings {
        let (place, text) = split_place(w);
        match order.iter_mut().find(|(_, t, _)| *t == text) {
            Some(entry) if place.is_some() => entry.2 += 1,
            _ => order.push((w.clone(), text, 1)),
        }
    }
    order
        .into_iter()
        .map(|(first, _, n)| match n {
            1 => first,
            n => format!("{first} (and {} more lines like it)", n - 1),
        })
        .collect()
}

/// `("file:12", "text")` for `"file:12: text"`; `(None, w)` without a
/// line number.
fn split_place(w: &str) -> (Option<&str>, &str) {
    let mut start = 0;
    while let Some(i) = w[start..].find(": ") {
        let head = &w[..start + i];
        let digits = head.rsplit(':').next().unwrap_or("");
        if head.contains(':') && !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) {
            return (Some(head), &w[start + i + 2..]);
        }
        start += i + 2;
    }
    (None, w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeats_fold_with_a_count_at_their_first_line() {
        let w: Vec<String> = [
            "g.nff:14: material index of refraction 0 replaced by 1",
            "g.nff:20: polygon skipped",
            "g.nff:1031: material index of refraction 0 replaced by 1",
            "g.nff:2042: material index of refraction 0 replaced by 1",
            "no lights",
        ]
        .map(String::from)
        .to_vec();
        assert_eq!(
            fold_repeated(&w),
            [
                "g.nff:14: material index of refraction 0 replaced by 1 (and 2 more lines like it)",
                "g.nff:20: polygon skipped",
                "no lights",
            ]
        );
    }

    #[test]
    fn messages_without_a_line_are_kept_as_they_are() {
        let w = vec!["same".to_string(), "same".to_string()];
        assert_eq!(fold_repeated(&w), w);
        assert_eq!(split_place("a.obj:3: x: y"), (Some("a.obj:3"), "x: y"));
        assert_eq!(
            split_place("C:/dir/a.nff:7: z"),
            (Some("C:/dir/a.nff:7"), "z")
        );
        assert_eq!(
            split_place("images[0]: missing"),
            (None, "images[0]: missing")
        );
    }
}
