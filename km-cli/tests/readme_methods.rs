//! The README and `km --help` name the same methods, as many as the
//! command's `--method` takes.

use std::path::PathBuf;
use std::process::Command;

fn help(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_km")).args(args).output().expect("run km");
    assert!(out.status.success());
    String::from_utf8(out.stdout).unwrap()
}

/// The number word of "by N methods".
fn count_word(text: &str) -> String {
    let at = text.find(" methods").expect("`by N methods`");
    text[..at].rsplit(' ').next().unwrap().to_string()
}

#[test]
fn readme_and_help_agree_on_the_methods() {
    let readme = std::fs::read_to_string(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("README.md"),
    )
    .unwrap();
    // The `--method` values of `km solve` (clap's list).
    let solve = help(&["solve", "--help"]);
    let list = solve
        .split("[possible values: ")
        .nth(1)
        .and_then(|t| t.split(']').next())
        .expect("possible values of --method");
    let methods: Vec<&str> = list.split(", ").collect();
    assert!(methods.len() >= 5, "{methods:?}");
    let words = ["one", "two", "three", "four", "five", "six", "seven", "eight"];
    let word = words[methods.len() - 1];
    // `km --help`: "by five methods", then one line per method.
    let top = help(&["--help"]);
    assert_eq!(count_word(&top), word, "{top}");
    for m in &methods {
        assert!(top.lines().any(|l| l.starts_with(&format!("{m} "))), "{m} in km --help: {top}");
    }
    // The README: the same number, a numbered item per method, each name
    // in the `km solve` row of its command table.
    assert_eq!(count_word(&readme), word, "the README's count of methods");
    // The list after "by N methods", up to the next section.
    let intro = &readme[readme.find(" methods").unwrap()..];
    let intro = &intro[..intro.find("\n## ").unwrap_or(intro.len())];
    let items = intro
        .lines()
        .filter(|l| l.split_once(". ").is_some_and(|(k, _)| k.parse::<usize>().is_ok()))
        .count();
    assert_eq!(items, methods.len(), "a numbered item per method in the README: {intro}");
    let row = readme
        .lines()
        .find(|l| l.starts_with("| `km solve SCENE --method M"))
        .expect("the km solve row");
    for m in &methods {
        assert!(row.contains(&format!("`{m}`")), "{m} in the README's row: {row}");
    }
}
