//! Where a TOML file is wrong: the line, column and dotted key
//! (`pwm.output[2].servo`, 0-based indices for arrays of tables) of a
//! toml/serde error or of a value's span. One helper for every TOML file
//! Furrow reads (the vehicle configuration of `furrow run`, SITL world
//! files), so each names its errors the same way.
//!
//! The key comes from the document's own syntax tree (toml's `DeTable`),
//! looked up by the error's span (`toml::de::Error::span`), never from the
//! error's message text. A document too broken to give a tree (a syntax
//! error, a duplicate key) is read line by line instead: the text before `=`
//! under the nearest `[table]` or `[[array]]` header above.

use std::ops::Range;

use toml::de::{DeTable, DeValue};

/// A 1-based line and column (in characters, not bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Place {
    pub line: usize,
    pub column: usize,
}

/// A toml/serde error placed in its document.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TomlProblem {
    /// `None` when the error is about the document as a whole.
    pub place: Option<Place>,
    /// Dotted key path; empty when no key is to blame. For a missing key it
    /// is the table that lacks it (the message names the key).
    pub key: String,
    /// toml's message, in TOML's words rather than Rust's (see [`plain_words`]).
    pub message: String,
}

/// The place of byte `offset` in `text` (clamped to the end).
pub fn place(text: &str, offset: usize) -> Place {
    let offset = offset.min(text.len());
    let before = text.get(..offset).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before.get(line_start..).map_or(0, |s| s.chars().count()) + 1;
    Place { line, column }
}

/// The source line (trimmed) holding byte `offset`.
pub fn source_line(text: &str, offset: usize) -> &str {
    let before = text.get(..offset.min(text.len())).unwrap_or(text);
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    text.get(line_start..)
        .unwrap_or_default()
        .lines()
        .next()
        .unwrap_or_default()
        .trim()
}

/// Places a toml/serde error from [`toml::from_str`] on `text`.
pub fn problem(text: &str, error: &toml::de::Error) -> TomlProblem {
    let message = plain_words(error.message().trim());
    match error.span() {
        Some(span) => TomlProblem {
            place: Some(place(text, span.start)),
            key: key_at(text, &span),
            message,
        },
        None => TomlProblem {
            place: None,
            key: String::new(),
            message,
        },
    }
}

/// The dotted key whose key or value has `span`; failing an exact match, of
/// the innermost value containing it; failing a tree, the line's best guess.
pub fn key_at(text: &str, span: &Range<usize>) -> String {
    match DeTable::parse(text) {
        Ok(root) => {
            let root = root.get_ref();
            let mut path = Vec::new();
            if find_in_table(root, span, true, &mut path) || find_in_table(root, span, false, &mut path) {
                render(&path)
            } else {
                String::new()
            }
        }
        Err(_) => key_from_lines(text, span.start),
    }
}

/// serde speaks of Rust's fields and types; a person editing a TOML file
/// thinks in keys and TOML's value kinds. Only words change: the message
/// is never read for meaning.
pub fn plain_words(message: &str) -> String {
    message
        .replace("missing field", "missing key")
        .replace("unknown field", "unknown key")
        .replace("expected i64", "expected an integer")
        .replace("expected f64", "expected a number")
        .replace("expected a boolean", "expected true or false")
}

#[derive(Clone)]
enum Segment {
    Key(String),
    Index(usize),
}

fn render(path: &[Segment]) -> String {
    let mut out = String::new();
    for segment in path {
        match segment {
            Segment::Key(k) => {
                if !out.is_empty() {
                    out.push('.');
                }
                out.push_str(k);
            }
            Segment::Index(i) => out.push_str(&format!("[{i}]")),
        }
    }
    out
}

fn matches(candidate: &Range<usize>, span: &Range<usize>, exact: bool) -> bool {
    if exact {
        candidate == span
    } else {
        candidate.start <= span.start && span.end <= candidate.end && candidate.start < candidate.end
    }
}

fn find_in_table(table: &DeTable<'_>, span: &Range<usize>, exact: bool, path: &mut Vec<Segment>) -> bool {
    for (key, value) in table.iter() {
        path.push(Segment::Key(key.get_ref().to_string()));
        if exact && key.span() == *span {
            return true;
        }
        // Children first: a table made implicitly by `[a.b]` shares its
        // header's span with `a.b`, and the deeper name is the useful one.
        if find_in_value(value.get_ref(), span, exact, path) || matches(&value.span(), span, exact) {
            return true;
        }
        path.pop();
    }
    false
}

fn find_in_value(value: &DeValue<'_>, span: &Range<usize>, exact: bool, path: &mut Vec<Segment>) -> bool {
    match value {
        DeValue::Table(table) => find_in_table(table, span, exact, path),
        DeValue::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                path.push(Segment::Index(i));
                if find_in_value(item.get_ref(), span, exact, path) || matches(&item.span(), span, exact) {
                    return true;
                }
                path.pop();
            }
            false
        }
        _ => false,
    }
}

/// A best guess at the key of a line that does not parse: the text before
/// `=` on the error's line, under the nearest header above it.
fn key_from_lines(text: &str, offset: usize) -> String {
    let before = text.get(..offset.min(text.len())).unwrap_or(text);
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let line = source_line(text, line_start);
    if let Some(name) = header(line, &text[..line_start]) {
        return name;
    }
    let table = header_above(&text[..line_start]).unwrap_or_default();
    let key = line
        .split_once('=')
        .map(|(k, _)| k.trim())
        .filter(|k| !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || "_-.\"' ".contains(c)))
        .unwrap_or_default();
    match (table.is_empty(), key.is_empty()) {
        (_, true) => table,
        (true, false) => key.to_string(),
        (false, false) => format!("{table}.{key}"),
    }
}

/// The name of the last `[table]` or `[[array]]` header in `text`, with its
/// index for an array of tables (`static[2]`).
fn header_above(text: &str) -> Option<String> {
    line_starts(text)
        .filter_map(|(start, line)| header(line, &text[..start]))
        .last()
}

/// `line` as a header (`[a.b]` → `a.b`, `[[a]]` → `a[N]` where N counts the
/// earlier `[[a]]` headers in `before`), or `None`.
fn header(line: &str, before: &str) -> Option<String> {
    let line = line.trim();
    if let Some(name) = array_header(line) {
        let index = before
            .lines()
            .filter(|l| array_header(l.trim()).is_some_and(|n| n == name))
            .count();
        return Some(format!("{name}[{index}]"));
    }
    line.strip_prefix('[')
        .and_then(|s| s.split_once(']'))
        .map(|(name, _)| name.trim().to_string())
}

fn array_header(line: &str) -> Option<&str> {
    line.strip_prefix("[[")
        .and_then(|s| s.split_once("]]"))
        .map(|(name, _)| name.trim())
}

fn line_starts(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut start = 0;
    text.split_inclusive('\n').map(move |line| {
        let here = start;
        start += line.len();
        (here, line.trim_end_matches(['\n', '\r']))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Doc {
        gnss: Option<Gnss>,
        #[serde(default)]
        output: Vec<Output>,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Gnss {
        baud: Option<i64>,
        fast: Option<bool>,
    }

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    #[allow(dead_code)]
    struct Output {
        servo: i64,
    }

    fn problem_of(text: &str) -> TomlProblem {
        match toml::from_str::<Doc>(text) {
            Ok(doc) => panic!("parsed: {doc:?}"),
            Err(e) => problem(text, &e),
        }
    }

    #[test]
    fn place_counts_characters() {
        let text = "a = 1\nbé = \"x\"\n";
        assert_eq!(place(text, 0), Place { line: 1, column: 1 });
        let x = text.find('"').unwrap_or_default();
        assert_eq!(place(text, x), Place { line: 2, column: 6 });
        assert_eq!(place(text, text.len() + 10), Place { line: 3, column: 1 });
    }

    #[test]
    fn wrong_types_and_unknown_keys_name_their_key_and_line() {
        let p = problem_of("[gnss]\nbaud = \"fast\"\n");
        assert_eq!(
            (p.key.as_str(), p.place.map(|p| p.line)),
            ("gnss.baud", Some(2)),
            "{p:?}"
        );
        assert!(p.message.contains("expected an integer"), "{p:?}");
        let p = problem_of("[gnss]\nfast = 1\n");
        assert!(p.message.contains("expected true or false"), "{p:?}");
        let p = problem_of("[gnss]\nbauds = 1\n");
        assert_eq!(
            (p.key.as_str(), p.place.map(|p| p.line)),
            ("gnss.bauds", Some(2)),
            "{p:?}"
        );
        assert!(p.message.contains("unknown key `bauds`"), "{p:?}");
    }

    #[test]
    fn a_missing_key_names_its_table_in_an_array() {
        let p = problem_of("[[output]]\nservo = 1\n[[output]]\n[[output]]\nservo = 3\n");
        assert_eq!(
            (p.key.as_str(), p.place.map(|p| p.line)),
            ("output[1]", Some(3)),
            "{p:?}"
        );
        assert!(p.message.contains("missing key `servo`"), "{p:?}");
    }

    #[test]
    fn a_syntax_error_is_placed_by_its_line() {
        let p = problem_of("[[output]]\nservo = 1\n[[output]]\nservo = = 2\n");
        assert_eq!(
            (p.key.as_str(), p.place.map(|p| p.line)),
            ("output[1].servo", Some(4)),
            "{p:?}"
        );
        let p = problem_of("[gnss]\nbaud = 1\nbaud = 2\n");
        assert_eq!(p.key, "gnss.baud", "{p:?}");
        assert_eq!(source_line("a = 1\n  b = 2  \n", 7), "b = 2");
    }
}
