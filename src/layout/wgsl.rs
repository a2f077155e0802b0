//! The GLSL that [`super::shader`] writes, as WGSL: a parser for the closed subset that module writes (functions,
//! structs, constant `uint` arrays, declarations, assignments, `if`/`for`/`return`, C expressions with the ternary)
//! and a printer in WGSL's spelling.
//!
//! Translating the one GLSL text, rather than writing every codec a third time, keeps the three languages the
//! same arithmetic by construction; the proof on the driver (tests/shader_glsl.rs) then checks the translation
//! too. What WGSL lacks is supplied around it by [`super::shader`]: `f64` (a software double on `vec2<u32>`),
//! `isnan`/`isinf` (bit tests, since WGSL lets an implementation assume no NaN or infinity exists), and resource
//! declarations (uniform structs with `@group`/`@binding`).
//!
//! Printing rules: GLSL scalar and vector types become `f32`/`u32`/`i32`/`vecN<T>`; every local is a `var`
//! (GLSL locals may be reassigned); a parameter the body assigns is copied into a `var` of its name; a ternary
//! is `select(else, then, cond)` (both sides are side-effect free here); a binary operand that is itself a binary
//! expression of another operator is parenthesised, since WGSL refuses to mix bitwise, shift and logical operators
//! with others without parentheses.

use std::fmt::Write as _;

/// GLSL → WGSL for the code `layout::shader` writes. `rename` maps identifiers (e.g. `gbuf_znear` →
/// `gbuf_camera.znear`). An error names the construct outside the subset (a bug in the emitter, not user input).
pub fn translate(glsl: &str, rename: &[(&str, &str)]) -> Result<String, String> {
    let toks = lex(glsl)?;
    let mut p = Parser {
        t: toks,
        i: 0,
        rename,
        vars: std::collections::HashMap::new(),
        funcs: std::collections::HashMap::new(),
        precise: std::cell::Cell::new(false),
    };
    let mut out = String::with_capacity(glsl.len() * 5 / 4);
    while !p.done() {
        p.item(&mut out)?;
    }
    Ok(out)
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    Num(String),
    Punct(&'static str),
    Comment(String),
    /// A blank line between items (kept so the output reads like the input).
    Blank,
}

const PUNCT: [&str; 36] = [
    "<<=", ">>=", "&&", "||", "==", "!=", "<=", ">=", "<<", ">>", "+=", "-=", "*=", "/=", "|=", "&=", "^=", "++", "--",
    "(", ")", "{", "}", "[", "]", ";", ",", ".", "?", ":", "+", "-", "*", "/", "=", "<",
];
const PUNCT1: [&str; 6] = [">", "!", "&", "|", "^", "%"];

fn lex(s: &str) -> Result<Vec<Tok>, String> {
    let b = s.as_bytes();
    let mut i = 0;
    let mut out = Vec::new();
    let mut newlines = 0;
    while i < b.len() {
        let c = b[i];
        if c == b'\n' {
            newlines += 1;
            if newlines == 2 {
                out.push(Tok::Blank);
            }
            i += 1;
            continue;
        }
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        newlines = 0;
        if s[i..].starts_with("//") {
            let end = s[i..].find('\n').map_or(s.len(), |e| i + e);
            out.push(Tok::Comment(s[i..end].to_string()));
            i = end;
        } else if c.is_ascii_alphabetic() || c == b'_' {
            let st = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            out.push(Tok::Ident(s[st..i].to_string()));
        } else if c.is_ascii_digit() || (c == b'.' && b.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            let st = i;
            while i < b.len()
                && (b[i].is_ascii_alphanumeric()
                    || b[i] == b'.'
                    || ((b[i] == b'-' || b[i] == b'+')
                        && matches!(b[i - 1], b'e' | b'E')
                        && !s[st..i].starts_with("0x")))
            {
                i += 1;
            }
            out.push(Tok::Num(s[st..i].to_string()));
        } else if let Some(p) = PUNCT.iter().chain(PUNCT1.iter()).find(|p| s[i..].starts_with(**p)) {
            out.push(Tok::Punct(p));
            i += p.len();
        } else {
            return Err(format!("unexpected character {:?} at byte {i}", &s[i..s.len().min(i + 20)]));
        }
    }
    Ok(out)
}

/// An expression of the subset.
#[derive(Debug)]
enum Expr {
    Atom(String),
    Call(String, Vec<Expr>),
    Unary(&'static str, Box<Expr>),
    Binary(&'static str, Box<Expr>, Box<Expr>),
    Ternary(Box<Expr>, Box<Expr>, Box<Expr>),
    Member(Box<Expr>, String),
    Index(Box<Expr>, Box<Expr>),
}

/// Binary operators by precedence, loosest first (C's table; the ternary sits above all of them).
const LEVELS: [&[&str]; 10] = [
    &["||"],
    &["&&"],
    &["|"],
    &["^"],
    &["&"],
    &["==", "!="],
    &["<", ">", "<=", ">="],
    &["<<", ">>"],
    &["+", "-"],
    &["*", "/", "%"],
];

/// GLSL type → WGSL type (`None`: not a type of the subset).
fn wgsl_type(t: &str) -> Option<String> {
    Some(match t {
        "float" => "f32".into(),
        "uint" => "u32".into(),
        "int" => "i32".into(),
        "bool" => "bool".into(),
        "GbufSurface" => t.into(),
        // gbuf's software double (f64.wgsl): the bits, low word first.
        "double" => "vec2<u32>".into(),
        _ => {
            let (elem, n) = if let Some(n) = t.strip_prefix("uvec") {
                ("u32", n)
            } else if let Some(n) = t.strip_prefix("ivec") {
                ("i32", n)
            } else if let Some(n) = t.strip_prefix("bvec") {
                ("bool", n)
            } else {
                ("f32", t.strip_prefix("vec")?)
            };
            if !matches!(n, "2" | "3" | "4") {
                return None;
            }
            format!("vec{n}<{elem}>")
        }
    })
}

/// GLSL built-in function → WGSL (`None`: same name).
fn wgsl_builtin(f: &str) -> Option<&'static str> {
    Some(match f {
        "uintBitsToFloat" => "bitcast<f32>",
        "floatBitsToUint" => "bitcast<u32>",
        "isnan" => "gbuf_isnan",
        "isinf" => "gbuf_isinf",
        // The emitted GLSL uses only the two-argument atan.
        "atan" => "atan2",
        _ => return None,
    })
}

struct Parser<'a> {
    t: Vec<Tok>,
    i: usize,
    rename: &'a [(&'a str, &'a str)],
    /// WGSL types of the current function's parameters and locals.
    vars: std::collections::HashMap<String, String>,
    /// WGSL return types of the functions parsed so far.
    funcs: std::collections::HashMap<String, String>,
    /// Printing a `precise` declaration: products added or subtracted are fenced (see [`FENCE`]).
    precise: std::cell::Cell<bool>,
}

/// What stands in for GLSL's `precise` in WGSL. Without it a compiler may rewrite floating-point arithmetic into
/// something that rounds differently: contract `a·b + c` into one rounding, or fold `sqrt(x)·sqrt(x)` to `x`
/// (Mesa does both; the CPU does neither). WGSL has no qualifier that forbids it, so the value of every `precise`
/// declaration, and every product that is added or subtracted, goes through a `select` on a bit pattern it never
/// has (all ones: a NaN only a NaN input carries, and every codec replaces NaN input before this arithmetic). No
/// compiler can see through the select, so each such value is rounded on its own, as the CPU rounds it.
pub const FENCE: &str = r"
// ---- what stands in for GLSL's `precise` (WGSL has none) ----
// The value, unless its bits are all ones (a NaN the codecs never compute). A compiler cannot see through the
// select, so it cannot contract or rewrite the arithmetic on either side of it into a different rounding.
fn gbuf_fence(v: f32) -> f32 {
    return select(v, 0.0, bitcast<u32>(v) == 0xffffffffu);
}
fn gbuf_fence2(v: vec2<f32>) -> vec2<f32> {
    return select(v, vec2<f32>(0.0), bitcast<vec2<u32>>(v) == vec2<u32>(0xffffffffu));
}
fn gbuf_fence3(v: vec3<f32>) -> vec3<f32> {
    return select(v, vec3<f32>(0.0), bitcast<vec3<u32>>(v) == vec3<u32>(0xffffffffu));
}
fn gbuf_fence4(v: vec4<f32>) -> vec4<f32> {
    return select(v, vec4<f32>(0.0), bitcast<vec4<u32>>(v) == vec4<u32>(0xffffffffu));
}
// a·b rounded on its own (not contracted into the add that takes it).
fn gbuf_mul(a: f32, b: f32) -> f32 {
    return gbuf_fence(a * b);
}
";

impl Parser<'_> {
    fn done(&self) -> bool {
        self.i >= self.t.len()
    }
    fn peek(&self) -> Option<&Tok> {
        self.t.get(self.i)
    }
    fn peek_at(&self, k: usize) -> Option<&Tok> {
        self.t.get(self.i + k)
    }
    fn is(&self, p: &str) -> bool {
        matches!(self.peek(), Some(Tok::Punct(q)) if *q == p)
    }
    fn is_word(&self, w: &str) -> bool {
        matches!(self.peek(), Some(Tok::Ident(q)) if q == w)
    }
    fn err<T>(&self, what: &str) -> Result<T, String> {
        let ctx: Vec<String> = self.t[self.i.min(self.t.len())..(self.i + 8).min(self.t.len())]
            .iter()
            .map(|t| match t {
                Tok::Ident(s) | Tok::Num(s) | Tok::Comment(s) => s.clone(),
                Tok::Punct(p) => (*p).to_string(),
                Tok::Blank => "¶".into(),
            })
            .collect();
        Err(format!("GLSL → WGSL: expected {what} at `{}`", ctx.join(" ")))
    }
    fn expect(&mut self, p: &str) -> Result<(), String> {
        if self.is(p) {
            self.i += 1;
            Ok(())
        } else {
            self.err(&format!("`{p}`"))
        }
    }
    fn ident(&mut self) -> Result<String, String> {
        match self.peek() {
            Some(Tok::Ident(s)) => {
                let s = s.clone();
                self.i += 1;
                Ok(s)
            }
            _ => self.err("a name"),
        }
    }
    fn skip_trivia(&mut self) {
        while matches!(self.peek(), Some(Tok::Blank | Tok::Comment(_))) {
            self.i += 1;
        }
    }
    fn name(&self, s: &str) -> String {
        self.rename.iter().find(|(a, _)| *a == s).map_or_else(|| s.to_string(), |(_, b)| (*b).to_string())
    }

    /// A top-level item: comment, blank line, struct, constant array or function.
    fn item(&mut self, out: &mut String) -> Result<(), String> {
        match self.peek() {
            Some(Tok::Comment(c)) => {
                let _ = writeln!(out, "{c}");
                self.i += 1;
            }
            Some(Tok::Blank) => {
                out.push('\n');
                self.i += 1;
            }
            _ if self.is_word("struct") => {
                self.i += 1;
                let name = self.ident()?;
                self.expect("{")?;
                let _ = writeln!(out, "struct {name} {{");
                while !self.is("}") {
                    self.skip_trivia();
                    let ty = self.ident()?;
                    let field = self.ident()?;
                    self.expect(";")?;
                    let _ = writeln!(out, "    {field}: {},", wgsl_type(&ty).ok_or(format!("type {ty}"))?);
                    self.skip_trivia();
                }
                self.expect("}")?;
                self.expect(";")?;
                out.push_str("}\n");
            }
            _ if self.is_word("const") => {
                // const uint NAME[N] = uint[N](a, b, …);
                self.i += 1;
                let ty = self.ident()?;
                let name = self.ident()?;
                self.expect("[")?;
                let n = self.expr()?;
                self.expect("]")?;
                self.expect("=")?;
                let _ = self.ident()?;
                self.expect("[")?;
                let _ = self.expr()?;
                self.expect("]")?;
                let args = self.args()?;
                self.expect(";")?;
                let t = wgsl_type(&ty).ok_or(format!("type {ty}"))?;
                let vals: Vec<String> = args.iter().map(|a| self.print(a)).collect();
                // A private variable rather than `const`: indexed at run time, which every WGSL compiler takes.
                let _ = writeln!(
                    out,
                    "var<private> {name}: array<{t}, {n}> = array<{t}, {n}>({});",
                    vals.join(", "),
                    n = self.print(&n)
                );
            }
            _ => self.function(out)?,
        }
        Ok(())
    }

    fn function(&mut self, out: &mut String) -> Result<(), String> {
        let ret = self.ident()?;
        let name = self.ident()?;
        self.expect("(")?;
        self.vars.clear();
        if let Some(t) = wgsl_type(&ret) {
            self.funcs.insert(name.clone(), t);
        }
        let mut params = Vec::new();
        while !self.is(")") {
            let ty = self.ident()?;
            let p = self.ident()?;
            let t = wgsl_type(&ty).ok_or(format!("parameter type {ty} of {name}"))?;
            self.vars.insert(p.clone(), t.clone());
            params.push((p, t));
            if self.is(",") {
                self.i += 1;
            }
        }
        self.expect(")")?;
        let start = self.i;
        let mut body = String::new();
        self.block(&mut body, 1)?;
        // Parameters the body assigns: WGSL parameters are immutable, so take them as `<p>_in` into a `var`.
        let assigned: Vec<bool> = params.iter().map(|(p, _)| self.assigns(start, self.i, p)).collect();
        let sig: Vec<String> = params
            .iter()
            .zip(&assigned)
            .map(|((p, t), &a)| if a { format!("{p}_in: {t}") } else { format!("{p}: {t}") })
            .collect();
        let ret = if ret == "void" {
            String::new()
        } else {
            format!(" -> {}", wgsl_type(&ret).ok_or(format!("type {ret}"))?)
        };
        let _ = writeln!(out, "fn {name}({}){ret} {{", sig.join(", "));
        for ((p, _), &a) in params.iter().zip(&assigned) {
            if a {
                let _ = writeln!(out, "    var {p} = {p}_in;");
            }
        }
        out.push_str(&body);
        out.push_str("}\n");
        Ok(())
    }

    /// Does the token range assign to `p` (`p = `, `p op= `, `p[...] op= `, `p++`)?
    fn assigns(&self, from: usize, to: usize, p: &str) -> bool {
        (from..to).any(|k| {
            if !matches!(&self.t[k], Tok::Ident(s) if s == p)
                || matches!(self.t.get(k.wrapping_sub(1)), Some(Tok::Punct(".")))
            {
                return false;
            }
            let mut j = k + 1;
            if matches!(self.t.get(j), Some(Tok::Punct("["))) {
                let mut depth = 0;
                while j < to {
                    match self.t[j] {
                        Tok::Punct("[") => depth += 1,
                        Tok::Punct("]") => {
                            depth -= 1;
                            if depth == 0 {
                                break;
                            }
                        }
                        _ => {}
                    }
                    j += 1;
                }
                j += 1;
            }
            matches!(
                self.t.get(j),
                Some(Tok::Punct("=" | "+=" | "-=" | "*=" | "/=" | "|=" | "&=" | "^=" | "<<=" | ">>=" | "++" | "--"))
            )
        })
    }

    /// `{ stmt* }` with the statements indented `depth` levels (the braces are the caller's).
    fn block(&mut self, out: &mut String, depth: usize) -> Result<(), String> {
        self.expect("{")?;
        loop {
            self.skip_trivia_into(out, depth);
            if self.is("}") {
                break;
            }
            self.stmt(out, depth)?;
        }
        self.expect("}")
    }

    fn skip_trivia_into(&mut self, out: &mut String, depth: usize) {
        while let Some(t) = self.peek() {
            match t {
                Tok::Comment(c) => {
                    let _ = writeln!(out, "{}{c}", "    ".repeat(depth));
                }
                Tok::Blank => {}
                _ => break,
            }
            self.i += 1;
        }
    }

    /// A statement as a braced body (WGSL's `if`/`for` need braces).
    fn body(&mut self, out: &mut String, depth: usize) -> Result<(), String> {
        out.push_str("{\n");
        if self.is("{") {
            self.block(out, depth + 1)?;
        } else {
            self.stmt(out, depth + 1)?;
        }
        let _ = write!(out, "{}}}", "    ".repeat(depth));
        Ok(())
    }

    fn stmt(&mut self, out: &mut String, depth: usize) -> Result<(), String> {
        let ind = "    ".repeat(depth);
        if self.is("{") {
            out.push_str(&ind);
            self.body(out, depth)?;
            out.push('\n');
            return Ok(());
        }
        if self.is_word("return") {
            self.i += 1;
            if self.is(";") {
                let _ = writeln!(out, "{ind}return;");
            } else {
                let e = self.expr()?;
                let _ = writeln!(out, "{ind}return {};", self.print(&e));
            }
            return self.expect(";");
        }
        if self.is_word("continue") || self.is_word("break") {
            let w = self.ident()?;
            let _ = writeln!(out, "{ind}{w};");
            return self.expect(";");
        }
        if self.is_word("if") {
            self.i += 1;
            self.expect("(")?;
            let c = self.expr()?;
            self.expect(")")?;
            let _ = write!(out, "{ind}if ({}) ", self.print(&c));
            self.body(out, depth)?;
            while self.is_word("else") {
                self.i += 1;
                if self.is_word("if") {
                    self.i += 1;
                    self.expect("(")?;
                    let c = self.expr()?;
                    self.expect(")")?;
                    let _ = write!(out, " else if ({}) ", self.print(&c));
                } else {
                    out.push_str(" else ");
                }
                self.body(out, depth)?;
            }
            out.push('\n');
            return Ok(());
        }
        if self.is_word("for") {
            self.i += 1;
            self.expect("(")?;
            let init = self.simple()?;
            self.expect(";")?;
            let cond = self.expr()?;
            self.expect(";")?;
            let step = self.simple()?;
            self.expect(")")?;
            let _ = write!(out, "{ind}for ({init}; {}; {step}) ", self.print(&cond));
            self.body(out, depth)?;
            out.push('\n');
            return Ok(());
        }
        let s = self.simple()?;
        self.expect(";")?;
        let _ = writeln!(out, "{ind}{s};");
        Ok(())
    }

    /// A declaration, assignment, increment or call, without its `;`.
    fn simple(&mut self) -> Result<String, String> {
        let precise = self.is_word("precise");
        if precise {
            self.i += 1;
        }
        // A declaration is a type name followed by a name.
        if let (Some(Tok::Ident(ty)), Some(Tok::Ident(_))) = (self.peek(), self.peek_at(1)) {
            if let Some(t) = wgsl_type(ty) {
                self.i += 1;
                let name = self.ident()?;
                self.vars.insert(name.clone(), t.clone());
                if self.is("=") {
                    self.i += 1;
                    let e = self.expr()?;
                    self.precise.set(precise);
                    let v = self.print(&e);
                    self.precise.set(false);
                    let fence = match t.as_str() {
                        "f32" => "gbuf_fence",
                        "vec2<f32>" => "gbuf_fence2",
                        "vec3<f32>" => "gbuf_fence3",
                        "vec4<f32>" => "gbuf_fence4",
                        _ => "",
                    };
                    if precise && !fence.is_empty() {
                        return Ok(format!("var {name}: {t} = {fence}({v})"));
                    }
                    return Ok(format!("var {name}: {t} = {v}"));
                }
                return Ok(format!("var {name}: {t}"));
            }
        }
        let lhs = self.postfix()?;
        for op in ["=", "+=", "-=", "*=", "/=", "|=", "&=", "^=", "<<=", ">>="] {
            if self.is(op) {
                self.i += 1;
                let e = self.expr()?;
                return Ok(format!("{} {op} {}", self.print(&lhs), self.print(&e)));
            }
        }
        for op in ["++", "--"] {
            if self.is(op) {
                self.i += 1;
                return Ok(format!("{}{op}", self.print(&lhs)));
            }
        }
        Ok(self.print(&lhs))
    }

    fn args(&mut self) -> Result<Vec<Expr>, String> {
        self.expect("(")?;
        let mut v = Vec::new();
        while !self.is(")") {
            v.push(self.expr()?);
            if self.is(",") {
                self.i += 1;
            } else if !self.is(")") {
                return self.err("`,` or `)`");
            }
        }
        self.expect(")")?;
        Ok(v)
    }

    fn expr(&mut self) -> Result<Expr, String> {
        let c = self.binary(0)?;
        if self.is("?") {
            self.i += 1;
            let a = self.expr()?;
            self.expect(":")?;
            let b = self.expr()?;
            return Ok(Expr::Ternary(Box::new(c), Box::new(a), Box::new(b)));
        }
        Ok(c)
    }

    fn binary(&mut self, level: usize) -> Result<Expr, String> {
        if level == LEVELS.len() {
            return self.unary();
        }
        let mut l = self.binary(level + 1)?;
        while let Some(Tok::Punct(p)) = self.peek() {
            let Some(op) = LEVELS[level].iter().find(|o| *o == p) else { break };
            self.i += 1;
            let r = self.binary(level + 1)?;
            l = Expr::Binary(op, Box::new(l), Box::new(r));
        }
        Ok(l)
    }

    fn unary(&mut self) -> Result<Expr, String> {
        for op in ["-", "!", "+"] {
            if self.is(op) {
                self.i += 1;
                let e = self.unary()?;
                return Ok(if op == "+" { e } else { Expr::Unary(op, Box::new(e)) });
            }
        }
        self.postfix()
    }

    fn postfix(&mut self) -> Result<Expr, String> {
        let mut e = match self.peek().cloned() {
            Some(Tok::Punct("(")) => {
                self.i += 1;
                let e = self.expr()?;
                self.expect(")")?;
                e
            }
            Some(Tok::Num(n)) => {
                self.i += 1;
                Expr::Atom(n)
            }
            Some(Tok::Ident(w)) => {
                self.i += 1;
                if self.is("(") {
                    Expr::Call(w, self.args()?)
                } else {
                    Expr::Atom(w)
                }
            }
            _ => return self.err("an expression"),
        };
        loop {
            if self.is(".") {
                self.i += 1;
                e = Expr::Member(Box::new(e), self.ident()?);
            } else if self.is("[") {
                self.i += 1;
                let k = self.expr()?;
                self.expect("]")?;
                e = Expr::Index(Box::new(e), Box::new(k));
            } else {
                return Ok(e);
            }
        }
    }

    /// Is `e` an f32 scalar? (What the fence needs to know; `false` when unsure.)
    fn is_f32(&self, e: &Expr) -> bool {
        match e {
            Expr::Atom(a) if a.starts_with(|c: char| c.is_ascii_digit()) => {
                !a.ends_with('u') && !a.starts_with("0x") && (a.contains('.') || a.contains('e'))
            }
            Expr::Atom(a) => self.vars.get(a).is_some_and(|t| t == "f32"),
            Expr::Member(x, m) => match &**x {
                Expr::Atom(a) if self.vars.get(a).is_some_and(|t| t == "GbufSurface") => {
                    matches!(m.as_str(), "depth" | "specular" | "specular_power" | "roughness" | "metallic")
                }
                Expr::Atom(a) => m.len() == 1 && self.vars.get(a).is_some_and(|t| t.ends_with("<f32>")),
                _ => m.len() == 1,
            },
            Expr::Index(x, _) => {
                matches!(&**x, Expr::Atom(a) if self.vars.get(a).is_some_and(|t| t.ends_with("<f32>")))
            }
            Expr::Call(f, args) => match f.as_str() {
                "float" => true,
                "clamp" | "max" | "min" | "abs" | "sqrt" => args.first().is_some_and(|a| self.is_f32(a)),
                _ => self.funcs.get(f).is_some_and(|t| t == "f32"),
            },
            Expr::Unary(_, x) => self.is_f32(x),
            Expr::Binary(op, a, b) => matches!(*op, "+" | "-" | "*" | "/") && self.is_f32(a) && self.is_f32(b),
            Expr::Ternary(_, a, b) => self.is_f32(a) && self.is_f32(b),
        }
    }

    fn print(&self, e: &Expr) -> String {
        match e {
            Expr::Atom(a) => {
                if a.ends_with("lf") {
                    return format!("/* double literal {a} outside the f64 helpers */");
                }
                self.name(a)
            }
            Expr::Call(f, args) => {
                let a: Vec<String> = args.iter().map(|x| self.print(x)).collect();
                let f = wgsl_builtin(f).map(str::to_string).or_else(|| wgsl_type(f)).unwrap_or_else(|| self.name(f));
                format!("{f}({})", a.join(", "))
            }
            Expr::Unary(op, x) => {
                let inner = self.print(x);
                match **x {
                    Expr::Atom(_) | Expr::Call(..) | Expr::Member(..) | Expr::Index(..) => format!("{op}{inner}"),
                    _ => format!("{op}({inner})"),
                }
            }
            Expr::Binary(op, l, r) => {
                let side = |x: &Expr, left: bool| {
                    if let Expr::Binary("*", a, b) = x {
                        if self.precise.get() && matches!(*op, "+" | "-") && self.is_f32(a) && self.is_f32(b) {
                            return format!("gbuf_mul({}, {})", self.print(a), self.print(b));
                        }
                    }
                    let s = self.print(x);
                    match x {
                        // Same operator on the left of a left-associative chain reads as written.
                        Expr::Binary(o, ..)
                            if left
                                && o == op
                                && !matches!(*op, "<<" | ">>" | "==" | "!=" | "<" | ">" | "<=" | ">=") =>
                        {
                            s
                        }
                        Expr::Binary(..) | Expr::Ternary(..) => format!("({s})"),
                        _ => s,
                    }
                };
                format!("{} {op} {}", side(l, true), side(r, false))
            }
            Expr::Ternary(c, a, b) => format!("select({}, {}, {})", self.print(b), self.print(a), self.print(c)),
            Expr::Member(x, m) => {
                let s = self.print(x);
                match **x {
                    Expr::Binary(..) | Expr::Unary(..) | Expr::Ternary(..) => format!("({s}).{m}"),
                    _ => format!("{s}.{m}"),
                }
            }
            Expr::Index(x, k) => format!("{}[{}]", self.print(x), self.print(k)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ternaries_become_select_and_mixed_operators_get_parentheses() {
        let w = translate("uint f(uint a, float v) { return isnan(v) ? a & 3u : a << 2u + 1u; }\n", &[]).unwrap();
        assert!(w.contains("fn f(a: u32, v: f32) -> u32 {"), "{w}");
        assert!(w.contains("return select(a << (2u + 1u), a & 3u, gbuf_isnan(v));"), "{w}");
    }

    #[test]
    fn assigned_parameters_are_copied_and_locals_are_vars() {
        let w = translate(
            "uvec4 put(uvec4 w, uint code, float g) {\n    code &= 7u;\n    w[1u] |= code;\n    precise float x = g * g + 1.0;\n    \
             float y = g * g + gbuf_znear;\n    return w;\n}\n",
            &[("gbuf_znear", "gbuf_camera.znear")],
        )
        .unwrap();
        assert!(w.contains("fn put(w_in: vec4<u32>, code_in: u32, g: f32) -> vec4<u32> {"), "{w}");
        assert!(w.contains("var w = w_in;") && w.contains("var code = code_in;"), "{w}");
        // `precise` becomes fences (the value, and a product that is added); plain arithmetic stays as it is.
        assert!(w.contains("var x: f32 = gbuf_fence(gbuf_mul(g, g) + 1.0);"), "{w}");
        assert!(w.contains("var y: f32 = (g * g) + gbuf_camera.znear;"), "{w}");
    }

    #[test]
    fn arrays_loops_and_structs() {
        let src = "struct S {\n    float a;\n    uvec3 b;\n};\nconst uint T[2] = uint[2](0x1u, 0x2u);\n\
                   uint g(float c) { uint lo = 0u; for (uint s = 2u; s > 0u; s >>= 1) { if (c >= uintBitsToFloat(T[lo])) lo += s; } return lo; }\n";
        let w = translate(src, &[]).unwrap();
        assert!(w.contains("struct S {\n    a: f32,\n    b: vec3<u32>,\n}"), "{w}");
        assert!(w.contains("var<private> T: array<u32, 2> = array<u32, 2>(0x1u, 0x2u);"), "{w}");
        assert!(w.contains("for (var s: u32 = 2u; s > 0u; s >>= 1) {"), "{w}");
        assert!(w.contains("if (c >= bitcast<f32>(T[lo])) {"), "{w}");
    }

    #[test]
    fn constructs_outside_the_subset_are_errors() {
        assert!(translate("float f() { return a @ b; }", &[]).is_err());
        assert!(translate("float f( { }", &[]).is_err());
    }
}
