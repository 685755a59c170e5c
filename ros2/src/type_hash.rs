//! ROS 2 type hashes (REP-2011): `RIHS01_` and the SHA-256 of the type's description, a JSON
//! document of the type and every type it refers to, written as `rosidl` writes it (fields in
//! their order, the referenced types sorted by name, `", "` and `": "` as separators). No Rust
//! crate computes these; the values are checked against those a ROS install and `rosbags` give.

use serde::ser::{SerializeMap, SerializeSeq};
use serde::{Serialize, Serializer};
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;

/// A message type: its name (`geometry_msgs/msg/WrenchStamped`) and fields in order.
#[derive(Debug)]
pub struct MessageType {
    pub name: &'static str,
    pub(crate) fields: &'static [Field],
}

#[derive(Debug)]
pub(crate) struct Field {
    pub(crate) name: &'static str,
    pub(crate) ty: FieldType,
}

/// The field types fringe's messages use (`type_description_interfaces/msg/FieldType` ids).
#[derive(Debug, Clone, Copy)]
pub(crate) enum FieldType {
    Uint8,
    Int32,
    Uint32,
    Float64,
    String,
    /// `uint8[]`.
    Uint8Sequence,
    Nested(&'static MessageType),
    /// `Type[]`.
    NestedSequence(&'static MessageType),
}

/// An unbounded sequence's type id is its element's plus this.
const UNBOUNDED_SEQUENCE: u8 = 144;

impl FieldType {
    fn type_id(self) -> u8 {
        match self {
            FieldType::Nested(_) => 1,
            FieldType::Uint8 => 3,
            FieldType::Int32 => 6,
            FieldType::Uint32 => 7,
            FieldType::Float64 => 11,
            FieldType::String => 17,
            FieldType::Uint8Sequence => 3 + UNBOUNDED_SEQUENCE,
            FieldType::NestedSequence(_) => 1 + UNBOUNDED_SEQUENCE,
        }
    }

    fn nested(self) -> Option<&'static MessageType> {
        match self {
            FieldType::Nested(t) | FieldType::NestedSequence(t) => Some(t),
            _ => None,
        }
    }
}

impl MessageType {
    /// The DDS name rmw implementations use for it: `geometry_msgs::msg::dds_::WrenchStamped_`.
    pub fn dds_name(&self) -> String {
        let mut parts = self.name.split('/');
        let (pkg, kind, name) = (
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
            parts.next().unwrap_or_default(),
        );
        format!("{pkg}::{kind}::dds_::{name}_")
    }

    /// Every type this one refers to, transitively, by name.
    fn referenced(&'static self, into: &mut BTreeMap<&'static str, &'static MessageType>) {
        for f in self.fields {
            if let Some(t) = f.ty.nested() {
                if into.insert(t.name, t).is_none() {
                    t.referenced(into);
                }
            }
        }
    }
}

/// A type's description as `rosidl` serialises it for the hash.
struct Description(&'static MessageType);

impl Serialize for Description {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("type_name", self.0.name)?;
        m.serialize_entry("fields", &Fields(self.0.fields))?;
        m.end()
    }
}

struct Fields(&'static [Field]);

impl Serialize for Fields {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(self.0.len()))?;
        for f in self.0 {
            seq.serialize_element(&FieldEntry(f))?;
        }
        seq.end()
    }
}

struct FieldEntry(&'static Field);

impl Serialize for FieldEntry {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("name", self.0.name)?;
        m.serialize_entry("type", &TypeEntry(self.0.ty))?;
        m.end()
    }
}

struct TypeEntry(FieldType);

impl Serialize for TypeEntry {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(4))?;
        m.serialize_entry("type_id", &self.0.type_id())?;
        m.serialize_entry("capacity", &0)?;
        m.serialize_entry("string_capacity", &0)?;
        m.serialize_entry("nested_type_name", self.0.nested().map_or("", |t| t.name))?;
        m.end()
    }
}

/// The document hashed: the type and the types it refers to, sorted by name.
struct Hashed(&'static MessageType);

impl Serialize for Hashed {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut refs = BTreeMap::new();
        self.0.referenced(&mut refs);
        let refs: Vec<Description> = refs.into_values().map(Description).collect();
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("type_description", &Description(self.0))?;
        m.serialize_entry("referenced_type_descriptions", &refs)?;
        m.end()
    }
}

/// Python's `json.dumps(separators=(", ", ": "))`, which `rosidl` hashes.
struct PythonSeparators;

impl serde_json::ser::Formatter for PythonSeparators {
    fn begin_array_value<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
        first: bool,
    ) -> std::io::Result<()> {
        if first {
            Ok(())
        } else {
            writer.write_all(b", ")
        }
    }

    fn begin_object_key<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
        first: bool,
    ) -> std::io::Result<()> {
        if first {
            Ok(())
        } else {
            writer.write_all(b", ")
        }
    }

    fn begin_object_value<W: ?Sized + std::io::Write>(
        &mut self,
        writer: &mut W,
    ) -> std::io::Result<()> {
        writer.write_all(b": ")
    }
}

/// The text hashed for `t` (see the module).
fn description_json(t: &'static MessageType) -> String {
    let mut out = Vec::new();
    let mut ser = serde_json::Serializer::with_formatter(&mut out, PythonSeparators);
    // Writing to a Vec cannot fail, and every key is a string.
    if Hashed(t).serialize(&mut ser).is_err() {
        return String::new();
    }
    String::from_utf8(out).unwrap_or_default()
}

impl FieldType {
    /// The field's type as a `.msg` file writes it: `float64`, `uint8[]`, `std_msgs/Header`.
    fn msg_type(self) -> String {
        match self {
            FieldType::Uint8 => "uint8".into(),
            FieldType::Int32 => "int32".into(),
            FieldType::Uint32 => "uint32".into(),
            FieldType::Float64 => "float64".into(),
            FieldType::String => "string".into(),
            FieldType::Uint8Sequence => "uint8[]".into(),
            FieldType::Nested(t) => t.short_name(),
            FieldType::NestedSequence(t) => format!("{}[]", t.short_name()),
        }
    }
}

impl MessageType {
    /// `pkg/Type`, as `.msg` files and MCAP's `MSG:` lines name a type.
    fn short_name(&self) -> String {
        self.name.replacen("/msg/", "/", 1)
    }

    /// The type's own `.msg` text: a `type name` line per field.
    fn msg_text(&self) -> String {
        self.fields
            .iter()
            .map(|f| format!("{} {}\n", f.ty.msg_type(), f.name))
            .collect()
    }

    /// Every type this one refers to, transitively, depth first, each once.
    fn dependencies(&'static self, into: &mut Vec<&'static MessageType>) {
        for f in self.fields {
            if let Some(t) = f.ty.nested() {
                if !into.iter().any(|d| d.name == t.name) {
                    into.push(t);
                    t.dependencies(into);
                }
            }
        }
    }
}

/// The message definition of `t` as ROS 2 bags and MCAP files carry it (schema encoding
/// `ros2msg`): the type's `.msg` text, then each type it refers to after a line of 80 `=` and a
/// line `MSG: pkg/Type`. Readers need every dependency, `builtin_interfaces/Time` included.
pub fn msg_definition(t: &'static MessageType) -> String {
    let mut out = t.msg_text();
    let mut deps = Vec::new();
    t.dependencies(&mut deps);
    for d in deps {
        out.push_str(&"=".repeat(80));
        out.push('\n');
        out.push_str(&format!("MSG: {}\n", d.short_name()));
        out.push_str(&d.msg_text());
    }
    out
}

/// `RIHS01_<sha256 hex>` of the type `t` (REP-2011).
pub fn type_hash(t: &'static MessageType) -> String {
    let digest = Sha256::digest(description_json(t).as_bytes());
    let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
    format!("RIHS01_{hex}")
}
