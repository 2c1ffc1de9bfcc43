//! The keys a request reads, from its own `Deserialize`: a test holds a front end's
//! options equal to them (every request key a `tprf render` flag, every flag a key),
//! and no list of them is written out by hand.

use serde::Deserialize;
use serde::de::{self, Deserializer, Visitor};

/// The serialised names of the fields of the struct `T` (after its `rename`s), as its
/// derived `Deserialize` hands them to a deserializer; empty for a type that is not a
/// struct.
pub fn serde_keys<'de, T: Deserialize<'de>>() -> &'static [&'static str] {
    let mut keys = Keys(None);
    // The deserializer refuses every value once it has seen the field names.
    let _ = T::deserialize(&mut keys);
    keys.0.unwrap_or(&[])
}

/// A deserializer that only records the field names of the struct asked of it.
struct Keys(Option<&'static [&'static str]>);

impl<'de> Deserializer<'de> for &mut Keys {
    type Error = de::value::Error;

    fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
        Err(de::Error::custom("only the field names are read"))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, Self::Error> {
        self.0 = Some(fields);
        Err(de::Error::custom("only the field names are read"))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes
        byte_buf option unit unit_struct newtype_struct seq tuple tuple_struct map enum
        identifier ignored_any
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize)]
    #[allow(dead_code, reason = "only its keys are read")]
    struct Two {
        a: u32,
        #[serde(rename = "b_s")]
        b: f64,
    }

    /// The names as serde reads them, renames applied; a non-struct has none.
    #[test]
    fn keys_are_the_serialised_names() {
        assert_eq!(serde_keys::<Two>(), ["a", "b_s"]);
        assert!(serde_keys::<u32>().is_empty());
        let keys = serde_keys::<crate::request::RenderRequest>();
        for k in ["scene", "t0", "dt", "filter", "max_memory", "sky"] {
            assert!(keys.contains(&k), "{k} not in {keys:?}");
        }
        assert!(!keys.contains(&"t0_s"));
    }
}
