//! From a model's text to items. Models wrap JSON in prose or code fences, stop mid-object
//! when they run out of tokens, and get single fields wrong; one bad item must not cost the
//! others, so items are read one by one and each failure becomes a refusal with its reason.

use super::check::Refused;
use super::item::Item;
use serde_json::Value;

/// Why no decision object could be read at all.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParseError {
    #[error("the answer holds no JSON object (it should be one object with an `actions` list)")]
    NoObject,
    #[error("the JSON object is cut off (the answer ended at character {at}); answer with a shorter, complete object")]
    Truncated { at: usize },
    #[error("the JSON is invalid at line {line}, column {column}: {message}")]
    Invalid { line: usize, column: usize, message: String },
    #[error("the object has no `{field}` list")]
    MissingList { field: &'static str },
}

/// The first JSON object in `text`: the answer itself, or the first one inside prose or a
/// code fence. Text after the object is ignored.
pub fn extract_json(text: &str) -> Result<Value, ParseError> {
    let start = text.find('{').ok_or(ParseError::NoObject)?;
    let mut stream = serde_json::Deserializer::from_str(&text[start..]).into_iter::<Value>();
    match stream.next() {
        Some(Ok(v)) => Ok(v),
        Some(Err(e)) if e.is_eof() => Err(ParseError::Truncated { at: text.chars().count() }),
        Some(Err(e)) => Err(ParseError::Invalid { line: e.line(), column: e.column(), message: e.to_string() }),
        None => Err(ParseError::NoObject),
    }
}

/// Items that fit the schema, with their indices in the model's list, and the refusals of
/// those that did not.
pub type ParsedItems = (Vec<(usize, Item)>, Vec<Refused>);

/// The items of a decision object's `field` list (`actions`), each with its index; items that
/// do not fit the schema are refused with the reason (and their unit, when it can be read).
pub fn parse_items(v: &Value, field: &'static str) -> Result<ParsedItems, ParseError> {
    let list = v.get(field).and_then(Value::as_array).ok_or(ParseError::MissingList { field })?;
    let (mut items, mut refused) = (Vec::new(), Vec::new());
    for (i, raw) in list.iter().enumerate() {
        match serde_json::from_value::<Item>(raw.clone()) {
            Ok(item) => items.push((i, item)),
            Err(e) => {
                let unit = raw.get("unit").and_then(Value::as_u64).and_then(|u| u32::try_from(u).ok());
                refused.push(Refused { item: i, unit, reason: format!("does not fit the schema: {e}") });
            }
        }
    }
    Ok((items, refused))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn objects_are_found_in_prose_and_fences() {
        let v = extract_json("Sure!\n```json\n{\"actions\": []}\n```\nThat's all.").expect("object");
        assert_eq!(v["actions"], Value::Array(vec![]));
        assert_eq!(extract_json("no json here"), Err(ParseError::NoObject));
        assert!(matches!(extract_json("{\"actions\": [{\"unit\": 1,"), Err(ParseError::Truncated { .. })));
        assert!(matches!(extract_json("{\"actions\": ]}"), Err(ParseError::Invalid { line: 1, .. })));
    }

    #[test]
    fn bad_items_are_refused_one_by_one() {
        let v = extract_json(r#"{"actions": [{"unit": 1, "action": "attack", "target": 4}, {"unit": 2, "action": "charge"}, 7]}"#)
            .expect("object");
        let (items, refused) = parse_items(&v, "actions").expect("list");
        assert_eq!(items.len(), 1);
        assert_eq!(refused.len(), 2);
        assert_eq!((refused[0].item, refused[0].unit), (1, Some(2)));
        assert!(refused[0].reason.contains("charge"), "{}", refused[0].reason);
        assert_eq!((refused[1].item, refused[1].unit), (2, None));
        assert_eq!(parse_items(&Value::Null, "actions"), Err(ParseError::MissingList { field: "actions" }));
    }
}
