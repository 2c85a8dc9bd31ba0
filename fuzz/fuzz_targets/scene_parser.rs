//! The scene parser on arbitrary bytes: every input is a scene or a refusal,
//! never a panic, and an accepted scene holds its invariants.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(scene) = km_core::Scene::from_toml_str(text) {
        assert!(!scene.channels().is_empty());
        assert_eq!(scene.labels().len(), scene.channels().len());
        for c in scene.channels() {
            // The parser builds through the checked constructor: rebuilding
            // from the parts gives the same channel.
            let again = km_core::MonoScene::new(
                c.light(),
                c.ambient_n(),
                c.layers().to_vec(),
                c.substrate(),
                c.directions_deg().to_vec(),
            );
            assert_eq!(again.as_ref(), Ok(c), "a parsed channel passes its constructor");
        }
        // The de-duplication maps every channel to an equal, earlier one.
        let first = km_core::plan::distinct_channels(&scene);
        for (i, &j) in first.iter().enumerate() {
            assert!(j <= i && scene.channels()[j] == scene.channels()[i]);
        }
    }
});
