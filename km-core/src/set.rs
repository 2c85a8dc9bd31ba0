//! Scene-file edits from the command line: `--set KEY=VALUE`.
//!
//! An edit replaces (or adds) one value of the scene file's TOML document
//! before the scene is validated, so every check of docs/scene-file.md
//! applies to the edited value and its errors name the key. Keys are spelled
//! as the error messages spell them: `layer[1].g` (1-based layer index),
//! `light.theta_deg`, `substrate.albedo`, `output.directions_deg`.

use toml_edit::{DocumentMut, Item, Value};

use crate::{CoreError, Scene};

/// One `KEY=VALUE` edit.
#[derive(Debug, Clone, PartialEq)]
pub struct SetEdit {
    /// The key path, e.g. `layer[1].g`.
    pub key: String,
    /// The value as TOML text, e.g. `0.8`, `[[0, 0], [30, 180]]`, `"milk"`
    /// (a bare word is taken as a string).
    pub value: String,
}

impl SetEdit {
    /// Split `KEY=VALUE`.
    ///
    /// # Errors
    /// A scene error on key `--set` when there is no `=` or the key is empty.
    ///
    /// ```
    /// let e = km_core::set::SetEdit::parse("layer[1].g=0.8").unwrap();
    /// assert_eq!((e.key.as_str(), e.value.as_str()), ("layer[1].g", "0.8"));
    /// assert!(km_core::set::SetEdit::parse("g").is_err());
    /// ```
    pub fn parse(text: &str) -> Result<SetEdit, CoreError> {
        match text.split_once('=') {
            Some((k, v)) if !k.trim().is_empty() => {
                Ok(SetEdit { key: k.trim().to_string(), value: v.trim().to_string() })
            }
            _ => Err(CoreError::scene(
                "--set",
                None,
                format!("`{text}`: expected KEY=VALUE, e.g. layer[1].g=0.8"),
            )),
        }
    }
}

/// One step of a key path: a table key, and for arrays of tables (`layer[2]`)
/// the 1-based index.
fn steps(key: &str) -> Result<Vec<(String, Option<usize>)>, CoreError> {
    let bad = |why: &str| CoreError::scene(key, None, format!("from --set: {why}"));
    key.split('.')
        .map(|part| {
            let (name, index) = match part.split_once('[') {
                Some((name, rest)) => {
                    let i = rest.strip_suffix(']').ok_or_else(|| bad("expected NAME[I]"))?;
                    let i: usize =
                        i.parse().map_err(|_| bad("the index in [I] is not a whole number"))?;
                    if i == 0 {
                        return Err(bad("indices are 1-based, as in the error messages"));
                    }
                    (name, Some(i))
                }
                None => (part, None),
            };
            if name.is_empty() {
                return Err(bad("empty key"));
            }
            Ok((name.to_string(), index))
        })
        .collect()
}

/// The TOML value of `text`; a bare word that is no TOML value is a string.
fn value_of(text: &str) -> Value {
    text.parse::<Value>().unwrap_or_else(|_| Value::from(text))
}

/// Apply `edit` to `doc`.
fn apply(doc: &mut DocumentMut, edit: &SetEdit) -> Result<(), CoreError> {
    let key = edit.key.as_str();
    let bad = |why: String| CoreError::scene(key, None, format!("from --set: {why}"));
    let steps = steps(key)?;
    let Some(((last, last_index), path)) = steps.split_last() else {
        return Err(bad("empty key".into()));
    };
    if last_index.is_some() {
        return Err(bad("the last part of the key names a value, not a table".into()));
    }
    let mut table = doc.as_table_mut() as &mut dyn toml_edit::TableLike;
    for (name, index) in path {
        let item = match index {
            None => {
                if table.get(name).is_none() {
                    table.insert(name, Item::Table(toml_edit::Table::new()));
                }
                table.get_mut(name).and_then(Item::as_table_like_mut)
            }
            Some(i) => {
                let n = table.get(name).and_then(Item::as_array_of_tables).map_or(0, |a| a.len());
                if *i > n {
                    return Err(bad(format!("the scene has {n} [[{name}]] entries, not {i}")));
                }
                table
                    .get_mut(name)
                    .and_then(Item::as_array_of_tables_mut)
                    .and_then(|a| a.get_mut(i - 1))
                    .map(|t| t as &mut dyn toml_edit::TableLike)
            }
        };
        table = item.ok_or_else(|| bad(format!("`{name}` is not a table")))?;
    }
    table.insert(last, Item::Value(value_of(&edit.value)));
    Ok(())
}

/// The first edit of `edits` after which `text` no longer validates, when
/// `text` alone does.
fn culprit<'a>(text: &str, edits: &'a [SetEdit]) -> Option<&'a SetEdit> {
    Scene::from_toml_str(text).ok()?;
    let mut doc: DocumentMut = text.parse().ok()?;
    for e in edits {
        apply(&mut doc, e).ok()?;
        if Scene::from_toml_str(&doc.to_string()).is_err() {
            return Some(e);
        }
    }
    None
}

impl Scene {
    /// Parse a scene file's text with `edits` applied first (`--set`).
    ///
    /// Each edit replaces or adds one value of the TOML document; the edited
    /// document is then validated like any scene file
    /// ([`Scene::from_toml_str`]). An error at an edited key says it came
    /// from `--set` (and gives no line of the file).
    ///
    /// # Errors
    /// Those of [`Scene::from_toml_str`], and a scene error naming the key
    /// when a key path does not fit the document (e.g. `layer[3]` of a
    /// two-layer scene).
    ///
    /// ```
    /// use km_core::{Scene, set::SetEdit};
    /// let text = "[[layer]]\ntau = 1\nalbedo = 0.9\ng = 0.2\n";
    /// let edit = SetEdit::parse("layer[1].g=0.8").unwrap();
    /// let s = Scene::from_toml_str_edited(text, &[edit]).unwrap();
    /// assert_eq!(s.channels()[0].layers()[0].g(), 0.8);
    /// let bad = SetEdit::parse("layer[1].g=2").unwrap();
    /// let e = Scene::from_toml_str_edited(text, &[bad]).unwrap_err().to_string();
    /// assert!(e.contains("layer[1].g") && e.contains("--set"), "{e}");
    /// ```
    pub fn from_toml_str_edited(text: &str, edits: &[SetEdit]) -> Result<Scene, CoreError> {
        if edits.is_empty() {
            return Scene::from_toml_str(text);
        }
        // A file TOML cannot read: its own error, as without edits.
        let mut doc: DocumentMut = match text.parse() {
            Ok(d) => d,
            Err(_) => return Scene::from_toml_str(text),
        };
        for e in edits {
            apply(&mut doc, e)?;
        }
        Scene::from_toml_str(&doc.to_string()).map_err(|err| {
            let CoreError::Scene { key, message, .. } = &err else {
                return err;
            };
            if edits.iter().any(|e| *key == e.key || key.starts_with(&format!("{}.", e.key))) {
                let e = edits.iter().rev().find(|e| key.starts_with(&e.key)).cloned();
                let from = e.map(|e| format!("{}={}", e.key, e.value)).unwrap_or_default();
                return CoreError::scene(
                    key.clone(),
                    None,
                    format!("{message} (from --set {from})"),
                );
            }
            // An error at another key (`scene`, a table's unknown field)
            // that the file alone does not have: the first edit that brings
            // it in is named, with no line of the file.
            match culprit(text, edits) {
                Some(e) => CoreError::scene(
                    e.key.clone(),
                    None,
                    format!("{message} (from --set {}={})", e.key, e.value),
                ),
                None => err,
            }
        })
    }

    /// Read a scene file and apply `edits` ([`Scene::from_toml_str_edited`]).
    ///
    /// # Errors
    /// Those of [`Scene::from_path`] and [`Scene::from_toml_str_edited`].
    pub fn from_path_edited(path: &std::path::Path, edits: &[SetEdit]) -> Result<Scene, CoreError> {
        // The file is read as `from_path` reads it (regular file or `-`, size limit).
        let limits = crate::scene::SceneLimits::from_env();
        let text = crate::scene::read_scene_text(path, limits.max_bytes)?;
        Scene::from_toml_str_edited(&text, edits)
    }
}
