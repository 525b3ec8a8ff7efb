//! The entities lump: `{ "key" "value" … }` blocks of text.

use super::BspError;

/// One entity: its key/value pairs in file order.
pub type Entity = Vec<(String, String)>;

fn err(offset: usize, message: impl Into<String>) -> BspError {
    BspError::Entities {
        offset,
        message: message.into(),
    }
}

/// Parses the entity text. A trailing NUL (and anything after it) ends the text.
pub fn parse(text: &[u8]) -> Result<Vec<Entity>, BspError> {
    let end = text.iter().position(|&b| b == 0).unwrap_or(text.len());
    let text = &text[..end];
    let mut entities = Vec::new();
    let mut i = 0;
    let skip_ws = |i: &mut usize| {
        while *i < text.len() && text[*i].is_ascii_whitespace() {
            *i += 1;
        }
    };
    let string = |i: &mut usize| -> Result<String, BspError> {
        skip_ws(i);
        if *i >= text.len() || text[*i] != b'"' {
            return Err(err(*i, "expected a quoted string"));
        }
        let start = *i + 1;
        match text[start..].iter().position(|&b| b == b'"') {
            Some(len) => {
                *i = start + len + 1;
                Ok(String::from_utf8_lossy(&text[start..start + len]).into_owned())
            }
            None => Err(err(*i, "unterminated string")),
        }
    };
    loop {
        skip_ws(&mut i);
        if i >= text.len() {
            break;
        }
        if text[i] != b'{' {
            return Err(err(
                i,
                format!("expected '{{' to open an entity, found {:?}", text[i] as char),
            ));
        }
        i += 1;
        let mut entity = Vec::new();
        loop {
            skip_ws(&mut i);
            match text.get(i) {
                None => return Err(err(i, "entity is not closed with '}'")),
                Some(b'}') => {
                    i += 1;
                    break;
                }
                Some(_) => {
                    let key = string(&mut i)?;
                    let value = string(&mut i)?;
                    entity.push((key, value));
                }
            }
        }
        entities.push(entity);
    }
    Ok(entities)
}

/// The value of `key` in `entity` (the first, case-sensitive as Quake 3 is).
pub fn get<'a>(entity: &'a Entity, key: &str) -> Option<&'a str> {
    entity.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_blocks_and_reports_errors() {
        let e = parse(b"{\n\"classname\" \"worldspawn\"\n}\n{ \"origin\" \"1 2 3\" \"a\" \"\" }\0junk").unwrap();
        assert_eq!(e.len(), 2);
        assert_eq!(get(&e[0], "classname"), Some("worldspawn"));
        assert_eq!(get(&e[1], "origin"), Some("1 2 3"));
        assert_eq!(get(&e[1], "a"), Some(""));
        assert!(matches!(parse(b"{ \"a\" }"), Err(BspError::Entities { .. })));
        assert!(matches!(parse(b"{ \"a\" \"b"), Err(BspError::Entities { .. })));
        assert!(matches!(parse(b"x"), Err(BspError::Entities { offset: 0, .. })));
        assert!(matches!(parse(b"{"), Err(BspError::Entities { .. })));
        assert!(parse(b"").unwrap().is_empty());
    }
}
