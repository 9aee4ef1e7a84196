//! The Foxglove layout in docs/foxglove/ names only channels a run has, and only fields their
//! schemas define: a renamed topic or field fails here, not silently in a user's Foxglove.

use ipc_types::TopicId;
use serde_json::Value;
use testbed_log::{TopicJson as _, foxglove};

fn layout() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../docs/foxglove/testbed.json"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Every string in `v`, with the key it is under.
fn strings<'a>(v: &'a Value, key: &'a str, out: &mut Vec<(&'a str, &'a str)>) {
    match v {
        Value::String(s) => out.push((key, s)),
        Value::Array(a) => a.iter().for_each(|x| strings(x, key, out)),
        Value::Object(o) => o.iter().for_each(|(k, x)| strings(x, k, out)),
        _ => {}
    }
}

fn schema_of(topic: &str) -> Option<Value> {
    let sample = TopicId::ALL.iter().find(|t| t.name() == topic);
    let text = match sample {
        Some(t) => t.json_schema(),
        None => {
            let i = foxglove::DERIVED_TOPICS.iter().position(|t| *t == topic)?;
            foxglove::derived_schemas()[i].1.to_owned()
        }
    };
    serde_json::from_str(&text).ok()
}

#[test]
fn every_topic_and_field_the_layout_names_exists() {
    let layout = layout();
    let mut found = Vec::new();
    strings(&layout["configById"], "", &mut found);
    let mut checked = 0;
    for (key, s) in found {
        if key == "topicToRender" || key == "topicName" {
            assert!(schema_of(s).is_some(), "{key} = {s}: no such channel");
            checked += 1;
        }
        // Message paths: "topic".field[index]
        if let Some(rest) = s.strip_prefix('"')
            && let Some((topic, path)) = rest.split_once('"')
        {
            let schema = schema_of(topic).unwrap_or_else(|| panic!("{s}: no channel {topic}"));
            let field = path
                .trim_start_matches('.')
                .split(['[', '.'])
                .next()
                .unwrap_or_default();
            assert!(
                schema["properties"][field].is_object(),
                "{s}: {topic} has no field {field}"
            );
            checked += 1;
        }
    }
    for topic in layout["configById"]["3D!platform"]["topics"]
        .as_object()
        .expect("3D topics")
        .keys()
    {
        assert!(schema_of(topic).is_some(), "3D panel topic {topic}");
        checked += 1;
    }
    // Nine plot lines, the mode indicator, the Log and Publish panels, two 3D topics.
    assert!(checked >= 14, "only {checked} names checked");
}
