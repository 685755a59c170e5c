//! A small, safe interpreter for Python pickles (protocols 2 to 5) that builds a tree of
//! values instead of objects: classes are named ([`Value::Global`]), never imported, calls are
//! recorded ([`Value::Call`]), never made.
//!
//! Written here rather than taken from a crate: serde-pickle cannot represent the globals and
//! persistent ids that `torch.save` writes, and candle would bring a whole framework for a few
//! hundred lines.
//!
//! Any input is safe: the interpreter never panics, reads each opcode's lengths against the
//! bytes that remain before allocating, bounds the nesting depth of values and the total size
//! of the values it builds (copies from the memo included), so it always ends, quickly, with a
//! value or a [`PickleError`].

use std::collections::HashMap;
use std::fmt;

/// Deepest nesting of containers accepted (a state dict needs fewer than 10 levels).
pub(crate) const MAX_DEPTH: u32 = 100;

/// Size units (about one per value, one per 8 bytes of text) any pickle may build, plus
/// [`COST_PER_INPUT_BYTE`] per byte of input.
const BASE_BUDGET: u64 = 1 << 20;
const COST_PER_INPUT_BYTE: u64 = 4;

/// A value read from a pickle.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    None,
    Bool(bool),
    Int(i64),
    /// An integer that does not fit in an i64: its little-endian two's complement bytes.
    BigInt(Vec<u8>),
    Float(f64),
    Str(String),
    Bytes(Vec<u8>),
    List(Vec<Value>),
    Tuple(Vec<Value>),
    /// A dict (or `collections.OrderedDict`), entries in the order the pickle set them.
    Dict(Vec<(Value, Value)>),
    /// A class or function by name (`GLOBAL` / `STACK_GLOBAL`), never imported.
    Global {
        module: String,
        name: String,
    },
    /// `callable(*args)` (`REDUCE`) or `cls.__new__(cls, *args)` (`NEWOBJ`), never called.
    Call {
        callable: Box<Value>,
        args: Box<Value>,
    },
    /// `obj.__setstate__(state)` (`BUILD`).
    Build {
        obj: Box<Value>,
        state: Box<Value>,
    },
    /// A reference to data kept outside the pickle (`BINPERSID`); torch's storages.
    PersistentId(Box<Value>),
}

impl Value {
    /// What kind of value this is, for messages ("a list", "collections.Counter(...)").
    pub fn describe(&self) -> String {
        match self {
            Value::None => "None".into(),
            Value::Bool(_) => "a bool".into(),
            Value::Int(_) | Value::BigInt(_) => "an int".into(),
            Value::Float(_) => "a float".into(),
            Value::Str(_) => "a str".into(),
            Value::Bytes(_) => "bytes".into(),
            Value::List(_) => "a list".into(),
            Value::Tuple(_) => "a tuple".into(),
            Value::Dict(_) => "a dict".into(),
            Value::Global { module, name } => format!("the class {module}.{name}"),
            Value::Call { callable, .. } => match callable.global() {
                Some((m, n)) => format!("an object {m}.{n}(...)"),
                None => "an object".into(),
            },
            Value::Build { obj, .. } => obj.describe(),
            Value::PersistentId(_) => "a persistent id".into(),
        }
    }

    /// `(module, name)` of a [`Value::Global`].
    pub fn global(&self) -> Option<(&str, &str)> {
        match self {
            Value::Global { module, name } => Some((module, name)),
            _ => None,
        }
    }

    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::Str(s) => Some(s),
            _ => None,
        }
    }

    pub fn as_int(&self) -> Option<i64> {
        match self {
            Value::Int(i) => Some(*i),
            Value::Bool(b) => Some(i64::from(*b)),
            _ => None,
        }
    }

    /// The items of a tuple or list.
    pub fn as_sequence(&self) -> Option<&[Value]> {
        match self {
            Value::Tuple(v) | Value::List(v) => Some(v),
            _ => None,
        }
    }

    /// The entries of a dict, also through a `BUILD` (an OrderedDict with `_metadata`).
    pub fn as_dict(&self) -> Option<&[(Value, Value)]> {
        match self {
            Value::Dict(d) => Some(d),
            Value::Build { obj, .. } => obj.as_dict(),
            _ => None,
        }
    }

    /// The value under the string key `key` of a dict.
    pub fn get(&self, key: &str) -> Option<&Value> {
        self.as_dict()?
            .iter()
            .find(|(k, _)| k.as_str() == Some(key))
            .map(|(_, v)| v)
    }
}

/// Why a pickle could not be read. `offset` is the byte of the opcode at fault.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PickleError {
    /// The input ended inside an opcode or before `STOP`.
    Truncated {
        offset: usize,
        needed: usize,
    },
    UnknownOpcode {
        offset: usize,
        opcode: u8,
    },
    /// An opcode needed more values than the stack (above the last mark) holds.
    StackUnderflow {
        offset: usize,
        opcode: u8,
    },
    /// A well-formed opcode that makes no sense here.
    Invalid {
        offset: usize,
        reason: String,
    },
    /// The pickle builds more (or deeper) than any model file needs.
    TooLarge {
        offset: usize,
        reason: String,
    },
}

impl fmt::Display for PickleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PickleError::Truncated { offset, needed } => write!(
                f,
                "ends at byte {offset}, {needed} more bytes needed (truncated)"
            ),
            PickleError::UnknownOpcode { offset, opcode } => {
                write!(f, "unknown opcode 0x{opcode:02x} at byte {offset}")
            }
            PickleError::StackUnderflow { offset, opcode } => {
                write!(f, "opcode 0x{opcode:02x} at byte {offset} on a short stack")
            }
            PickleError::Invalid { offset, reason } => write!(f, "at byte {offset}: {reason}"),
            PickleError::TooLarge { offset, reason } => write!(f, "at byte {offset}: {reason}"),
        }
    }
}

impl std::error::Error for PickleError {}

/// Reads one pickle that fills `bytes` (trailing bytes after `STOP` are refused).
pub fn parse(bytes: &[u8]) -> Result<Value, PickleError> {
    let (value, used) = parse_prefix(bytes)?;
    if used != bytes.len() {
        return Err(PickleError::Invalid {
            offset: used,
            reason: format!("{} bytes after STOP", bytes.len() - used),
        });
    }
    Ok(value)
}

/// Reads the pickle at the start of `bytes`; returns it and the number of bytes it used
/// (torch's legacy format puts several pickles and raw data one after another).
pub fn parse_prefix(bytes: &[u8]) -> Result<(Value, usize), PickleError> {
    let budget = BASE_BUDGET.saturating_add(COST_PER_INPUT_BYTE.saturating_mul(bytes.len() as u64));
    let mut m = Machine {
        input: bytes,
        pos: 0,
        op_start: 0,
        opcode: 0,
        stack: Vec::new(),
        marks: Vec::new(),
        memo: HashMap::new(),
        spent: 0,
        budget,
    };
    let value = m.run()?;
    Ok((value, m.pos))
}

/// A value on the stack or in the memo with its nesting depth and size.
#[derive(Debug, Clone)]
struct Item {
    value: Value,
    depth: u32,
    cost: u64,
}

struct Machine<'a> {
    input: &'a [u8],
    pos: usize,
    op_start: usize,
    opcode: u8,
    stack: Vec<Item>,
    /// Stack lengths at each MARK.
    marks: Vec<usize>,
    memo: HashMap<u32, Item>,
    spent: u64,
    budget: u64,
}

mod op {
    pub(super) const MARK: u8 = b'(';
    pub(super) const STOP: u8 = b'.';
    pub(super) const POP: u8 = b'0';
    pub(super) const POP_MARK: u8 = b'1';
    pub(super) const DUP: u8 = b'2';
    pub(super) const BININT: u8 = b'J';
    pub(super) const BININT1: u8 = b'K';
    pub(super) const BININT2: u8 = b'M';
    pub(super) const NONE: u8 = b'N';
    pub(super) const BINPERSID: u8 = b'Q';
    pub(super) const REDUCE: u8 = b'R';
    pub(super) const BINSTRING: u8 = b'T';
    pub(super) const SHORT_BINSTRING: u8 = b'U';
    pub(super) const BINUNICODE: u8 = b'X';
    pub(super) const APPEND: u8 = b'a';
    pub(super) const BUILD: u8 = b'b';
    pub(super) const GLOBAL: u8 = b'c';
    pub(super) const DICT: u8 = b'd';
    pub(super) const EMPTY_DICT: u8 = b'}';
    pub(super) const APPENDS: u8 = b'e';
    pub(super) const BINGET: u8 = b'h';
    pub(super) const LONG_BINGET: u8 = b'j';
    pub(super) const LIST: u8 = b'l';
    pub(super) const EMPTY_LIST: u8 = b']';
    pub(super) const BINPUT: u8 = b'q';
    pub(super) const LONG_BINPUT: u8 = b'r';
    pub(super) const SETITEM: u8 = b's';
    pub(super) const TUPLE: u8 = b't';
    pub(super) const EMPTY_TUPLE: u8 = b')';
    pub(super) const SETITEMS: u8 = b'u';
    pub(super) const BINFLOAT: u8 = b'G';
    pub(super) const PROTO: u8 = 0x80;
    pub(super) const NEWOBJ: u8 = 0x81;
    pub(super) const TUPLE1: u8 = 0x85;
    pub(super) const TUPLE2: u8 = 0x86;
    pub(super) const TUPLE3: u8 = 0x87;
    pub(super) const NEWTRUE: u8 = 0x88;
    pub(super) const NEWFALSE: u8 = 0x89;
    pub(super) const LONG1: u8 = 0x8a;
    pub(super) const LONG4: u8 = 0x8b;
    pub(super) const BINBYTES: u8 = b'B';
    pub(super) const SHORT_BINBYTES: u8 = b'C';
    pub(super) const SHORT_BINUNICODE: u8 = 0x8c;
    pub(super) const BINUNICODE8: u8 = 0x8d;
    pub(super) const BINBYTES8: u8 = 0x8e;
    pub(super) const STACK_GLOBAL: u8 = 0x93;
    pub(super) const MEMOIZE: u8 = 0x94;
    pub(super) const FRAME: u8 = 0x95;
}

/// Globals whose call with no arguments makes an (ordered) dict.
fn makes_dict(callable: &Value) -> bool {
    matches!(
        callable.global(),
        Some(("collections", "OrderedDict"))
            | Some(("collections", "defaultdict"))
            | Some(("builtins", "dict"))
            | Some(("__builtin__", "dict"))
    )
}

impl Machine<'_> {
    fn run(&mut self) -> Result<Value, PickleError> {
        loop {
            self.op_start = self.pos;
            let opcode = self.byte()?;
            self.opcode = opcode;
            match opcode {
                op::PROTO => {
                    let v = self.byte()?;
                    if !(2..=5).contains(&v) {
                        return Err(self.invalid(format!("pickle protocol {v} (2 to 5 supported)")));
                    }
                }
                op::FRAME => {
                    // Frames only help buffered readers: the bytes inside are ordinary opcodes.
                    self.take(8)?;
                }
                op::STOP => {
                    let item = self.pop()?;
                    return Ok(item.value);
                }
                op::MARK => self.marks.push(self.stack.len()),
                op::POP => {
                    self.pop()?;
                }
                op::POP_MARK => {
                    self.pop_mark()?;
                }
                op::DUP => {
                    let cost = self.peek()?.cost;
                    self.charge(cost)?;
                    let top = self.peek()?.clone();
                    self.stack.push(top);
                }
                op::NONE => self.push_leaf(Value::None, 1)?,
                op::NEWTRUE => self.push_leaf(Value::Bool(true), 1)?,
                op::NEWFALSE => self.push_leaf(Value::Bool(false), 1)?,
                op::BININT => {
                    let b = self.array::<4>()?;
                    self.push_leaf(Value::Int(i64::from(i32::from_le_bytes(b))), 1)?;
                }
                op::BININT1 => {
                    let b = self.byte()?;
                    self.push_leaf(Value::Int(i64::from(b)), 1)?;
                }
                op::BININT2 => {
                    let b = self.array::<2>()?;
                    self.push_leaf(Value::Int(i64::from(u16::from_le_bytes(b))), 1)?;
                }
                op::LONG1 => {
                    let n = usize::from(self.byte()?);
                    let bytes = self.take(n)?;
                    let v = long_value(bytes);
                    self.push_leaf(v, 1 + n as u64 / 8)?;
                }
                op::LONG4 => {
                    let n = self.len_u32()?;
                    let bytes = self.take(n)?;
                    let v = long_value(bytes);
                    self.push_leaf(v, 1 + n as u64 / 8)?;
                }
                op::BINFLOAT => {
                    let b = self.array::<8>()?;
                    self.push_leaf(Value::Float(f64::from_be_bytes(b)), 1)?;
                }
                op::SHORT_BINUNICODE => {
                    let n = usize::from(self.byte()?);
                    self.push_str(n)?;
                }
                op::BINUNICODE => {
                    let n = self.len_u32()?;
                    self.push_str(n)?;
                }
                op::BINUNICODE8 => {
                    let n = self.len_u64()?;
                    self.push_str(n)?;
                }
                op::SHORT_BINSTRING => {
                    let n = usize::from(self.byte()?);
                    let s = String::from_utf8_lossy(self.take(n)?).into_owned();
                    self.push_leaf(Value::Str(s), 1 + n as u64 / 8)?;
                }
                op::BINSTRING => {
                    let n = self.len_u32()?;
                    let s = String::from_utf8_lossy(self.take(n)?).into_owned();
                    self.push_leaf(Value::Str(s), 1 + n as u64 / 8)?;
                }
                op::SHORT_BINBYTES => {
                    let n = usize::from(self.byte()?);
                    self.push_bytes(n)?;
                }
                op::BINBYTES => {
                    let n = self.len_u32()?;
                    self.push_bytes(n)?;
                }
                op::BINBYTES8 => {
                    let n = self.len_u64()?;
                    self.push_bytes(n)?;
                }
                op::EMPTY_DICT => self.push_leaf(Value::Dict(Vec::new()), 1)?,
                op::EMPTY_LIST => self.push_leaf(Value::List(Vec::new()), 1)?,
                op::EMPTY_TUPLE => self.push_leaf(Value::Tuple(Vec::new()), 1)?,
                op::TUPLE => {
                    let items = self.pop_mark()?;
                    self.push_container(items, Value::Tuple)?;
                }
                op::TUPLE1 | op::TUPLE2 | op::TUPLE3 => {
                    let n = usize::from(opcode - op::TUPLE1 + 1);
                    let items = self.pop_n(n)?;
                    self.push_container(items, Value::Tuple)?;
                }
                op::LIST => {
                    let items = self.pop_mark()?;
                    self.push_container(items, Value::List)?;
                }
                op::DICT => {
                    let items = self.pop_mark()?;
                    let dict = self.pairs(items)?;
                    self.stack.push(dict);
                }
                op::APPEND => {
                    let item = self.pop()?;
                    self.extend_list(vec![item])?;
                }
                op::APPENDS => {
                    let items = self.pop_mark()?;
                    self.extend_list(items)?;
                }
                op::SETITEM => {
                    let items = self.pop_n(2)?;
                    self.extend_dict(items)?;
                }
                op::SETITEMS => {
                    let items = self.pop_mark()?;
                    self.extend_dict(items)?;
                }
                op::BINPUT => {
                    let i = self.byte()?;
                    self.memoize(u32::from(i))?;
                }
                op::LONG_BINPUT => {
                    let i = u32::from_le_bytes(self.array::<4>()?);
                    self.memoize(i)?;
                }
                op::MEMOIZE => {
                    let i = u32::try_from(self.memo.len())
                        .map_err(|_| self.too_large("memo of more than 2^32 values".into()))?;
                    self.memoize(i)?;
                }
                op::BINGET => {
                    let i = self.byte()?;
                    self.get(u32::from(i))?;
                }
                op::LONG_BINGET => {
                    let i = u32::from_le_bytes(self.array::<4>()?);
                    self.get(i)?;
                }
                op::GLOBAL => {
                    let module = self.line()?;
                    let name = self.line()?;
                    let cost = 1 + (module.len() + name.len()) as u64 / 8;
                    self.push_leaf(Value::Global { module, name }, cost)?;
                }
                op::STACK_GLOBAL => {
                    let mut items = self.pop_n(2)?;
                    let name = items.pop().map(|i| i.value);
                    let module = items.pop().map(|i| i.value);
                    match (module, name) {
                        (Some(Value::Str(module)), Some(Value::Str(name))) => {
                            let cost = 1 + (module.len() + name.len()) as u64 / 8;
                            self.push_leaf(Value::Global { module, name }, cost)?;
                        }
                        _ => return Err(self.invalid("STACK_GLOBAL of non-strings".into())),
                    }
                }
                op::REDUCE | op::NEWOBJ => {
                    let mut items = self.pop_n(2)?;
                    let (Some(args), Some(callable)) = (items.pop(), items.pop()) else {
                        return Err(self.underflow());
                    };
                    if makes_dict(&callable.value) {
                        // `OrderedDict()`: an empty dict that SETITEMS will fill.
                        self.push_leaf(Value::Dict(Vec::new()), 1)?;
                    } else {
                        let depth = callable.depth.max(args.depth) + 1;
                        let cost = callable.cost + args.cost + 1;
                        let value = Value::Call {
                            callable: Box::new(callable.value),
                            args: Box::new(args.value),
                        };
                        self.push_built(value, depth, cost)?;
                    }
                }
                op::BUILD => {
                    let mut items = self.pop_n(2)?;
                    let (Some(state), Some(obj)) = (items.pop(), items.pop()) else {
                        return Err(self.underflow());
                    };
                    let depth = obj.depth.max(state.depth) + 1;
                    let cost = obj.cost + state.cost + 1;
                    let value = Value::Build {
                        obj: Box::new(obj.value),
                        state: Box::new(state.value),
                    };
                    self.push_built(value, depth, cost)?;
                }
                op::BINPERSID => {
                    let pid = self.pop()?;
                    let value = Value::PersistentId(Box::new(pid.value));
                    self.push_built(value, pid.depth + 1, pid.cost + 1)?;
                }
                other => {
                    return Err(PickleError::UnknownOpcode {
                        offset: self.op_start,
                        opcode: other,
                    })
                }
            }
        }
    }

    fn invalid(&self, reason: String) -> PickleError {
        PickleError::Invalid {
            offset: self.op_start,
            reason,
        }
    }

    fn too_large(&self, reason: String) -> PickleError {
        PickleError::TooLarge {
            offset: self.op_start,
            reason,
        }
    }

    fn underflow(&self) -> PickleError {
        PickleError::StackUnderflow {
            offset: self.op_start,
            opcode: self.opcode,
        }
    }

    /// The next `n` bytes, if the input has them (checked before anything is allocated).
    fn take(&mut self, n: usize) -> Result<&[u8], PickleError> {
        let remaining = self.input.len() - self.pos;
        if n > remaining {
            return Err(PickleError::Truncated {
                offset: self.input.len(),
                needed: n - remaining,
            });
        }
        let start = self.pos;
        self.pos += n;
        Ok(&self.input[start..start + n])
    }

    fn byte(&mut self) -> Result<u8, PickleError> {
        Ok(self.take(1)?[0])
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], PickleError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N)?);
        Ok(out)
    }

    fn len_u32(&mut self) -> Result<usize, PickleError> {
        let n = u32::from_le_bytes(self.array::<4>()?);
        Ok(usize::try_from(n).unwrap_or(usize::MAX))
    }

    fn len_u64(&mut self) -> Result<usize, PickleError> {
        let n = u64::from_le_bytes(self.array::<8>()?);
        Ok(usize::try_from(n).unwrap_or(usize::MAX))
    }

    /// A newline-terminated line (GLOBAL's module and name).
    fn line(&mut self) -> Result<String, PickleError> {
        let rest = &self.input[self.pos..];
        let Some(end) = rest.iter().position(|&b| b == b'\n') else {
            return Err(PickleError::Truncated {
                offset: self.input.len(),
                needed: 1,
            });
        };
        let text = String::from_utf8_lossy(&rest[..end]).into_owned();
        self.pos += end + 1;
        Ok(text)
    }

    fn push_str(&mut self, n: usize) -> Result<(), PickleError> {
        let bytes = self.take(n)?;
        let s =
            std::str::from_utf8(bytes)
                .map(str::to_owned)
                .map_err(|_| PickleError::Invalid {
                    offset: self.op_start,
                    reason: "string that is not UTF-8".into(),
                })?;
        self.push_leaf(Value::Str(s), 1 + n as u64 / 8)
    }

    fn push_bytes(&mut self, n: usize) -> Result<(), PickleError> {
        let bytes = self.take(n)?.to_vec();
        self.push_leaf(Value::Bytes(bytes), 1 + n as u64 / 8)
    }

    /// Counts `cost` against the budget.
    fn charge(&mut self, cost: u64) -> Result<(), PickleError> {
        self.spent = self.spent.saturating_add(cost);
        if self.spent > self.budget {
            return Err(self.too_large(format!(
                "builds more than {} values (a copy bomb?)",
                self.budget
            )));
        }
        Ok(())
    }

    fn push_leaf(&mut self, value: Value, cost: u64) -> Result<(), PickleError> {
        self.charge(cost)?;
        self.stack.push(Item {
            value,
            depth: 1,
            cost,
        });
        Ok(())
    }

    /// Pushes a value made of popped items (already paid for) plus one node.
    fn push_built(&mut self, value: Value, depth: u32, cost: u64) -> Result<(), PickleError> {
        self.charge(1)?;
        self.check_depth(depth)?;
        self.stack.push(Item { value, depth, cost });
        Ok(())
    }

    fn check_depth(&self, depth: u32) -> Result<(), PickleError> {
        if depth > MAX_DEPTH {
            return Err(self.too_large(format!("values nested more than {MAX_DEPTH} deep")));
        }
        Ok(())
    }

    fn push_container(
        &mut self,
        items: Vec<Item>,
        make: fn(Vec<Value>) -> Value,
    ) -> Result<(), PickleError> {
        let depth = items.iter().map(|i| i.depth).max().unwrap_or(0) + 1;
        let cost = items.iter().map(|i| i.cost).sum::<u64>() + 1;
        let value = make(items.into_iter().map(|i| i.value).collect());
        self.push_built(value, depth, cost)
    }

    /// A dict from alternating keys and values.
    fn pairs(&mut self, items: Vec<Item>) -> Result<Item, PickleError> {
        if !items.len().is_multiple_of(2) {
            return Err(self.invalid("dict items of odd count".into()));
        }
        self.charge(1)?;
        let depth = items.iter().map(|i| i.depth).max().unwrap_or(0) + 1;
        self.check_depth(depth)?;
        let cost = items.iter().map(|i| i.cost).sum::<u64>() + 1;
        let mut entries = Vec::with_capacity(items.len() / 2);
        let mut it = items.into_iter();
        while let (Some(k), Some(v)) = (it.next(), it.next()) {
            entries.push((k.value, v.value));
        }
        Ok(Item {
            value: Value::Dict(entries),
            depth,
            cost,
        })
    }

    fn pop(&mut self) -> Result<Item, PickleError> {
        let floor = self.marks.last().copied().unwrap_or(0);
        if self.stack.len() <= floor {
            return Err(self.underflow());
        }
        self.stack.pop().ok_or_else(|| self.underflow())
    }

    fn peek(&self) -> Result<&Item, PickleError> {
        let floor = self.marks.last().copied().unwrap_or(0);
        if self.stack.len() <= floor {
            return Err(self.underflow());
        }
        self.stack.last().ok_or_else(|| self.underflow())
    }

    fn pop_n(&mut self, n: usize) -> Result<Vec<Item>, PickleError> {
        let floor = self.marks.last().copied().unwrap_or(0);
        if self.stack.len() < floor + n {
            return Err(self.underflow());
        }
        Ok(self.stack.split_off(self.stack.len() - n))
    }

    /// The items above the last MARK, removing the mark.
    fn pop_mark(&mut self) -> Result<Vec<Item>, PickleError> {
        let Some(mark) = self.marks.pop() else {
            return Err(self.invalid("no MARK before this opcode".into()));
        };
        if mark > self.stack.len() {
            return Err(self.underflow());
        }
        Ok(self.stack.split_off(mark))
    }

    /// The stack's top as a mutable target (list or dict) with room for `depth`.
    fn target(&mut self) -> Result<&mut Item, PickleError> {
        let floor = self.marks.last().copied().unwrap_or(0);
        if self.stack.len() <= floor {
            return Err(self.underflow());
        }
        let offset = self.op_start;
        let opcode = self.opcode;
        self.stack
            .last_mut()
            .ok_or(PickleError::StackUnderflow { offset, opcode })
    }

    fn extend_list(&mut self, items: Vec<Item>) -> Result<(), PickleError> {
        self.grow(items.iter().map(|i| (i.depth, i.cost)))?;
        let offset = self.op_start;
        let target = self.target()?;
        match &mut target.value {
            Value::List(list) => {
                list.extend(items.into_iter().map(|i| i.value));
                Ok(())
            }
            other => Err(PickleError::Invalid {
                offset,
                reason: format!("APPEND to {}", other.describe()),
            }),
        }
    }

    fn extend_dict(&mut self, items: Vec<Item>) -> Result<(), PickleError> {
        if !items.len().is_multiple_of(2) {
            return Err(self.invalid("dict items of odd count".into()));
        }
        self.grow(items.iter().map(|i| (i.depth, i.cost)))?;
        let offset = self.op_start;
        let target = self.target()?;
        match &mut target.value {
            Value::Dict(dict) => {
                let mut it = items.into_iter();
                while let (Some(k), Some(v)) = (it.next(), it.next()) {
                    dict.push((k.value, v.value));
                }
                Ok(())
            }
            other => Err(PickleError::Invalid {
                offset,
                reason: format!("SETITEM on {}", other.describe()),
            }),
        }
    }

    /// Updates the top's depth and size for children of `(depth, cost)` about to be added.
    fn grow(&mut self, children: impl Iterator<Item = (u32, u64)>) -> Result<(), PickleError> {
        let (mut depth, mut cost) = (0u32, 0u64);
        for (d, c) in children {
            depth = depth.max(d);
            cost = cost.saturating_add(c);
        }
        let top_depth = self.target()?.depth;
        let new_depth = top_depth.max(depth.saturating_add(1));
        self.check_depth(new_depth)?;
        let target = self.target()?;
        target.depth = new_depth;
        target.cost = target.cost.saturating_add(cost);
        Ok(())
    }

    fn memoize(&mut self, index: u32) -> Result<(), PickleError> {
        let cost = self.peek()?.cost;
        self.charge(cost)?;
        let top = self.peek()?.clone();
        self.memo.insert(index, top);
        Ok(())
    }

    fn get(&mut self, index: u32) -> Result<(), PickleError> {
        let Some(cost) = self.memo.get(&index).map(|i| i.cost) else {
            return Err(self.invalid(format!("memo entry {index} read before it was stored")));
        };
        self.charge(cost)?;
        if let Some(item) = self.memo.get(&index).cloned() {
            self.stack.push(item);
        }
        Ok(())
    }
}

/// LONG1 / LONG4 payload: little-endian two's complement.
fn long_value(bytes: &[u8]) -> Value {
    if bytes.is_empty() {
        return Value::Int(0);
    }
    if bytes.len() <= 8 {
        let negative = bytes[bytes.len() - 1] & 0x80 != 0;
        let mut buf = [if negative { 0xff } else { 0 }; 8];
        buf[..bytes.len()].copy_from_slice(bytes);
        return Value::Int(i64::from_le_bytes(buf));
    }
    Value::BigInt(bytes.to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(text: &str) -> Value {
        Value::Str(text.into())
    }

    #[test]
    fn reads_a_protocol_2_ordered_dict_with_persistent_ids() {
        // collections.OrderedDict() filled with SETITEMS, memo reuse, a persistent id tuple.
        let mut p = vec![0x80, 2];
        p.extend(b"ccollections\nOrderedDict\nq\x00)Rq\x01(");
        p.extend(b"X\x01\x00\x00\x00a");
        p.extend(b"(X\x07\x00\x00\x00storageq\x02K\x05\x8a\x01\xfft");
        p.push(b'Q');
        p.extend(b"X\x01\x00\x00\x00bh\x02u.");
        let v = parse(&p).expect("parses");
        let pid = Value::PersistentId(Box::new(Value::Tuple(vec![
            s("storage"),
            Value::Int(5),
            Value::Int(-1),
        ])));
        assert_eq!(v, Value::Dict(vec![(s("a"), pid), (s("b"), s("storage"))]));
    }

    #[test]
    fn protocol_4_frames_stack_globals_and_memoize() {
        let mut p = vec![0x80, 4, 0x95];
        p.extend(30u64.to_le_bytes());
        p.extend(b"\x8c\x05torch\x94\x8c\x04Size\x94\x93\x94K\x02K\x03\x86\x94R\x94.");
        let v = parse(&p).expect("parses");
        assert_eq!(
            v,
            Value::Call {
                callable: Box::new(Value::Global {
                    module: "torch".into(),
                    name: "Size".into()
                }),
                args: Box::new(Value::Tuple(vec![Value::Int(2), Value::Int(3)])),
            }
        );
    }

    #[test]
    fn refuses_truncated_deep_and_copy_bomb_pickles() {
        assert!(matches!(
            parse(b"\x80\x02X\x10\x00\x00\x00ab"),
            Err(PickleError::Truncated { .. })
        ));
        assert!(matches!(
            parse(b"\x80\x02K\x01"),
            Err(PickleError::Truncated { .. })
        ));
        let mut deep = vec![0x80, 2, b'N'];
        deep.extend(vec![0x85; 500]);
        deep.push(b'.');
        assert!(matches!(parse(&deep), Err(PickleError::TooLarge { .. })));
        // A list appended to a copy of itself, over and over: doubles each time.
        let mut bomb = vec![0x80, 2, b']', b'N', b'a'];
        for _ in 0..60 {
            bomb.extend(b"2a");
        }
        bomb.push(b'.');
        assert!(matches!(parse(&bomb), Err(PickleError::TooLarge { .. })));
        // A big list copied through the memo many times.
        let mut memo = vec![0x80, 2, b']', b'('];
        memo.extend(vec![b'N'; 4000]);
        memo.extend(b"eq\x00(");
        memo.extend(b"h\x00".repeat(2000));
        memo.extend(b"l.");
        assert!(matches!(parse(&memo), Err(PickleError::TooLarge { .. })));
    }
}
