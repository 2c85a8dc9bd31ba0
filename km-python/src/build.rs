//! Scenes from Python values, by way of the scene file.
//!
//! A scene built from keyword arguments is first written as the TOML table of
//! the scene file (`docs/scene-file.md`) and then parsed by
//! [`km::Scene::from_toml_str`], so it meets exactly the validation and
//! the messages of `km check` and `km solve`. The line numbers of such a
//! message would point into generated text, so they are dropped: the error
//! names the key (`layer[2].albedo`) and the problem.

use km::{CoreError, Scene};

use crate::error::Error;

/// Parse and validate the scene of a TOML table built in code; returns the
/// scene and its TOML text (which `km check` accepts as a file).
///
/// # Errors
/// Those of the scene file ([`CoreError::Scene`]), without line numbers.
///
/// ```
/// let mut layer = toml::Table::new();
/// layer.insert("tau".into(), 1.0.into());
/// layer.insert("albedo".into(), 1.5.into());
/// let mut t = toml::Table::new();
/// t.insert("layer".into(), toml::Value::Array(vec![layer.into()]));
/// let e = _km::build::scene_from_table(&t).unwrap_err();
/// assert_eq!(e.key(), Some("layer[1].albedo"));
/// assert_eq!(e.line(), None);
/// ```
pub fn scene_from_table(table: &toml::Table) -> Result<(Scene, String), Error> {
    let text = toml::to_string(table).map_err(|e| {
        Error::Scene(CoreError::scene("scene", None, format!("cannot write as TOML: {e}")))
    })?;
    match Scene::from_toml_str(&text) {
        Ok(scene) => Ok((scene, text)),
        Err(CoreError::Scene { key, message, .. }) => {
            Err(Error::Scene(CoreError::Scene { key, line: None, message }))
        }
        Err(e) => Err(Error::Scene(e)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layer(pairs: &[(&str, toml::Value)]) -> toml::Value {
        toml::Value::Table(pairs.iter().map(|(k, v)| (k.to_string(), v.clone())).collect())
    }

    #[test]
    fn a_table_gives_the_scene_of_the_same_file() {
        // The same scene written by hand must parse to the same value.
        let mut t = toml::Table::new();
        t.insert(
            "layer".into(),
            toml::Value::Array(vec![layer(&[
                ("sigma_a", 0.1.into()),
                ("sigma_s", toml::Value::Array(vec![0.4.into(), 0.5.into()])),
                ("thickness", "inf".into()),
                ("g", 0.3.into()),
            ])]),
        );
        let (scene, text) = scene_from_table(&t).unwrap();
        let by_hand = Scene::from_toml_str(
            "[[layer]]\nsigma_a = 0.1\nsigma_s = [0.4, 0.5]\nthickness = \"inf\"\ng = 0.3\n",
        )
        .unwrap();
        assert_eq!(scene, by_hand);
        assert_eq!(Scene::from_toml_str(&text).unwrap(), scene);
    }

    #[test]
    fn unknown_keys_are_named_without_a_line() {
        let mut t = toml::Table::new();
        t.insert("layer".into(), toml::Value::Array(vec![layer(&[("sigmaa", 0.1.into())])]));
        let e = scene_from_table(&t).unwrap_err();
        assert_eq!(e.key(), Some("sigmaa"));
        assert_eq!(e.line(), None);
        assert!(e.to_string().contains("unknown field `sigmaa`"), "{e}");
    }
}
