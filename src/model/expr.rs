//! Arithmetic expressions of effect files, compiled once to a small stack
//! program and to nested closures ([`Expr::eval`] runs the closures), and
//! evaluated without allocation.
//!
//! Why our own: an effect's force is evaluated at every stage of every step
//! of the numerical engine (some 10^4 times per record), so evaluation must
//! not allocate or look names up. The expression crates on crates.io either
//! evaluate through a string-keyed context (`evalexpr`, `meval`), allocate per
//! evaluation, or are unmaintained (`fasteval`). What effect files need is
//! small: numbers, named variables resolved to slots at compile time, the four
//! operations and a power, and a dozen functions. A recursive-descent parser
//! to postfix code is about two hundred lines.
//!
//! # Grammar
//! ```text
//! expr   = term (('+' | '-') term)*
//! term   = unary (('*' | '/') unary)*
//! unary  = '-' unary | power
//! power  = atom ('^' unary)?          (right-associative; -x^2 = -(x^2))
//! atom   = number | name | name '(' expr (',' expr)* ')' | '(' expr ')'
//! ```
//! Functions: `abs sqrt exp ln sin cos tan tanh atan sgn` (one argument),
//! `min max pow atan2` (two).
//!
//! ```
//! use hbis::model::expr::Expr;
//!
//! let e = Expr::compile("r_m * k0 * (u - q) + max(0, -u)^2", &["u", "q", "r_m", "k0"])?;
//! let v = e.eval(&[0.1, 0.04, 0.2, 10.0]);
//! assert!((v - 0.2 * 10.0 * 0.06).abs() < 1e-15);
//! assert!(Expr::compile("u + w", &["u"]).unwrap_err().to_string().contains("`w`"));
//! # Ok::<(), hbis::model::expr::ExprError>(())
//! ```

use thiserror::Error;

/// Deepest evaluation stack an expression may need.
pub const MAX_DEPTH: usize = 32;

/// An expression that cannot be compiled.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ExprError {
    /// A name that is neither a variable nor a function.
    #[error("unknown symbol `{name}` at column {column} (known: {known})")]
    Unknown {
        name: String,
        column: usize,
        known: String,
    },
    /// Anything else the grammar does not allow.
    #[error("{what} at column {column}")]
    Syntax { what: String, column: usize },
}

#[derive(Debug, Clone, Copy)]
enum Op {
    Num(f64),
    Var(usize),
    Neg,
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    F1(fn(f64) -> f64),
    F2(fn(f64, f64) -> f64),
    // Fused forms (see `fuse`): a binary operation whose right operand is a
    // variable or a number, and the two commonest functions called directly.
    AddV(usize),
    SubV(usize),
    MulV(usize),
    DivV(usize),
    AddN(f64),
    SubN(f64),
    MulN(f64),
    DivN(f64),
    Abs,
    Sgn,
}

/// The code with each binary operation whose right operand is a leaf (a
/// variable or a number) fused with it: half the dispatches on an
/// effect's typical `c * abs(v) * v` (`abs` and `sgn`, its commonest
/// functions, are their own operations, called without a pointer). The
/// same operations on the same operands in the same order, so the values
/// are the same to the bit. The stack a fused code needs is at most the
/// unfused code's.
fn fuse(code: Vec<Op>) -> Vec<Op> {
    let mut out: Vec<Op> = Vec::with_capacity(code.len());
    for op in code {
        let fused = match (out.last().copied(), op) {
            (Some(Op::Var(i)), Op::Add) => Some(Op::AddV(i)),
            (Some(Op::Var(i)), Op::Sub) => Some(Op::SubV(i)),
            (Some(Op::Var(i)), Op::Mul) => Some(Op::MulV(i)),
            (Some(Op::Var(i)), Op::Div) => Some(Op::DivV(i)),
            (Some(Op::Num(c)), Op::Add) => Some(Op::AddN(c)),
            (Some(Op::Num(c)), Op::Sub) => Some(Op::SubN(c)),
            (Some(Op::Num(c)), Op::Mul) => Some(Op::MulN(c)),
            (Some(Op::Num(c)), Op::Div) => Some(Op::DivN(c)),
            _ => None,
        };
        match fused {
            Some(f) => *out.last_mut().expect("a leaf precedes") = f,
            None => out.push(op),
        }
    }
    out
}

/// How an expression varies with variables that are constant, affine
/// coordinates or anything else ([`Expr::degree`]), least first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Degree {
    /// The same value throughout.
    Constant,
    /// A constant plus constants times affine coordinates.
    Affine,
    /// Neither.
    Other,
}

/// A compiled expression: postfix code over numbered variables, and the
/// same code as nested closures that [`Expr::eval`] runs.
#[derive(Clone)]
pub struct Expr {
    code: Vec<Op>,
    text: String,
    tree: Option<Node>,
}

impl std::fmt::Debug for Expr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Expr")
            .field("code", &self.code)
            .field("text", &self.text)
            .finish_non_exhaustive()
    }
}

/// A node of [`tree`]: its value at the variables.
type Node = std::sync::Arc<dyn Fn(&[f64]) -> f64 + Send + Sync>;

/// Longest code run as closures: their evaluation recurses once per
/// nesting level, which a long chain of terms makes as deep as it is long.
/// Longer code runs on the stack machine ([`Expr::run`]).
const TREE_MAX: usize = 256;

/// `code` as nested closures, each operation one closure over its
/// operands: the same operations on the same operands (left operand
/// first), so the values are the stack machine's to the bit. The
/// stack machine dispatches every operation through one indirect jump,
/// which the processor mispredicts along an expression; each closure calls
/// its operands from its own code. `None` for code longer than
/// [`TREE_MAX`].
fn tree(code: &[Op]) -> Option<Node> {
    use std::sync::Arc;
    if code.len() > TREE_MAX {
        return None;
    }
    let mut st: Vec<Node> = Vec::with_capacity(MAX_DEPTH);
    for &op in code {
        let node: Node = match op {
            Op::Num(v) => Arc::new(move |_: &[f64]| v),
            Op::Var(i) => Arc::new(move |x: &[f64]| x[i]),
            Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Pow | Op::F2(_) => {
                let b = st.pop()?;
                let a = st.pop()?;
                match op {
                    Op::Add => Arc::new(move |x: &[f64]| a(x) + b(x)),
                    Op::Sub => Arc::new(move |x: &[f64]| a(x) - b(x)),
                    Op::Mul => Arc::new(move |x: &[f64]| a(x) * b(x)),
                    Op::Div => Arc::new(move |x: &[f64]| a(x) / b(x)),
                    Op::Pow => Arc::new(move |x: &[f64]| a(x).powf(b(x))),
                    Op::F2(f) => Arc::new(move |x: &[f64]| f(a(x), b(x))),
                    _ => unreachable!("binary operations only"),
                }
            }
            unary => {
                let a = st.pop()?;
                match unary {
                    Op::Neg => Arc::new(move |x: &[f64]| -a(x)),
                    Op::F1(f) => Arc::new(move |x: &[f64]| f(a(x))),
                    Op::Abs => Arc::new(move |x: &[f64]| a(x).abs()),
                    Op::Sgn => Arc::new(move |x: &[f64]| sgn(a(x))),
                    Op::AddV(i) => Arc::new(move |x: &[f64]| a(x) + x[i]),
                    Op::SubV(i) => Arc::new(move |x: &[f64]| a(x) - x[i]),
                    Op::MulV(i) => Arc::new(move |x: &[f64]| a(x) * x[i]),
                    Op::DivV(i) => Arc::new(move |x: &[f64]| a(x) / x[i]),
                    Op::AddN(c) => Arc::new(move |x: &[f64]| a(x) + c),
                    Op::SubN(c) => Arc::new(move |x: &[f64]| a(x) - c),
                    Op::MulN(c) => Arc::new(move |x: &[f64]| a(x) * c),
                    Op::DivN(c) => Arc::new(move |x: &[f64]| a(x) / c),
                    _ => unreachable!("leaves and binary operations handled above"),
                }
            }
        };
        st.push(node);
    }
    let root = st.pop()?;
    st.is_empty().then_some(root)
}

fn sgn(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

fn function1(name: &str) -> Option<fn(f64) -> f64> {
    Some(match name {
        "abs" => f64::abs,
        "sqrt" => f64::sqrt,
        "exp" => f64::exp,
        "ln" => f64::ln,
        "sin" => f64::sin,
        "cos" => f64::cos,
        "tan" => f64::tan,
        "tanh" => f64::tanh,
        "atan" => f64::atan,
        "sgn" => sgn,
        _ => return None,
    })
}

fn function2(name: &str) -> Option<fn(f64, f64) -> f64> {
    Some(match name {
        "min" => f64::min,
        "max" => f64::max,
        "pow" => f64::powf,
        "atan2" => f64::atan2,
        _ => return None,
    })
}

/// The deepest stack that unfused `code` needs.
fn depth(code: &[Op]) -> usize {
    let (mut d, mut most) = (0usize, 0usize);
    for op in code {
        match op {
            Op::Num(_) | Op::Var(_) => d += 1,
            Op::Add | Op::Sub | Op::Mul | Op::Div | Op::Pow | Op::F2(_) => d -= 1,
            _ => {}
        }
        most = most.max(d);
    }
    most
}

/// Whether `name` is a function of the expression language.
pub fn is_function(name: &str) -> bool {
    function1(name).is_some() || function2(name).is_some()
}

impl Expr {
    /// Compiles `text`; `vars` names the variables, in the order of the
    /// slice [`eval`](Self::eval) takes.
    pub fn compile(text: &str, vars: &[&str]) -> Result<Self, ExprError> {
        let code = fuse(parse(text, vars)?);
        Ok(Self {
            tree: tree(&code),
            code,
            text: text.to_string(),
        })
    }

    /// The source text.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Whether it reads variable `i`.
    pub fn uses(&self, i: usize) -> bool {
        self.code
            .iter()
            .any(|op| matches!(op, Op::Var(j) | Op::AddV(j) | Op::SubV(j) | Op::MulV(j) | Op::DivV(j) if *j == i))
    }

    /// How it depends on the variables, given how each variable varies
    /// (`of_var`): [`Degree::Constant`], [`Degree::Affine`] (a sum of the
    /// affine variables times constants, plus a constant) or
    /// [`Degree::Other`]. A product of two non-constant operands, a
    /// division by one, a power or a function of one is `Other`, whatever
    /// the values (`u * u` is not affine, even where `u` stays small).
    ///
    /// ```
    /// use hbis::model::expr::{Degree, Expr};
    ///
    /// let of_var = |i: usize| [Degree::Affine, Degree::Constant][i];
    /// let degree = |text: &str| Expr::compile(text, &["u", "c"]).unwrap().degree(&of_var);
    /// assert_eq!(degree("c * (u - 2)"), Degree::Affine);
    /// assert_eq!(degree("exp(c) * u + c^2 / 3"), Degree::Affine);
    /// assert_eq!(degree("max(c, 1) / 3"), Degree::Constant);
    /// assert_eq!(degree("u * u"), Degree::Other);
    /// assert_eq!(degree("abs(u)"), Degree::Other);
    /// assert_eq!(degree("c / u"), Degree::Other);
    /// # Ok::<(), hbis::model::expr::ExprError>(())
    /// ```
    pub fn degree(&self, of_var: &dyn Fn(usize) -> Degree) -> Degree {
        use Degree::{Affine, Constant, Other};
        let mut st: Vec<Degree> = Vec::with_capacity(MAX_DEPTH);
        let product = |a: Degree, b: Degree| match (a, b) {
            (Other, _) | (_, Other) | (Affine, Affine) => Other,
            (Constant, Constant) => Constant,
            _ => Affine,
        };
        let quotient = |a: Degree, b: Degree| if b == Constant { a } else { Other };
        let function = |a: Degree| if a == Constant { Constant } else { Other };
        for op in &self.code {
            let top = st.pop();
            let d = match (*op, top) {
                (Op::Num(_), _) | (Op::Var(_), _) => {
                    st.extend(top);
                    match *op {
                        Op::Var(i) => of_var(i),
                        _ => Constant,
                    }
                }
                (_, None) => return Other,
                (Op::Neg, Some(a)) => a,
                (Op::F1(_) | Op::Abs | Op::Sgn, Some(a)) => function(a),
                (Op::AddV(i) | Op::SubV(i), Some(a)) => a.max(of_var(i)),
                (Op::MulV(i), Some(a)) => product(a, of_var(i)),
                (Op::DivV(i), Some(a)) => quotient(a, of_var(i)),
                (Op::AddN(_) | Op::SubN(_) | Op::MulN(_) | Op::DivN(_), Some(a)) => a,
                (op, Some(b)) => {
                    let Some(a) = st.pop() else {
                        return Other;
                    };
                    match op {
                        Op::Add | Op::Sub => a.max(b),
                        Op::Mul => product(a, b),
                        Op::Div => quotient(a, b),
                        _ => function(a.max(b)),
                    }
                }
            };
            st.push(d);
        }
        match (st.pop(), st.is_empty()) {
            (Some(d), true) => d,
            _ => Other,
        }
    }

    /// Its value with the variables `x` (in the order given to
    /// [`compile`](Self::compile)); no allocation.
    pub fn eval(&self, x: &[f64]) -> f64 {
        match &self.tree {
            Some(root) => root(x),
            None => self.run(x),
        }
    }

    /// Its value, by the stack machine.
    fn run(&self, x: &[f64]) -> f64 {
        let mut st = [0.0f64; MAX_DEPTH];
        let mut n = 0usize;
        for op in &self.code {
            match *op {
                Op::Num(v) => {
                    st[n] = v;
                    n += 1;
                }
                Op::Var(i) => {
                    st[n] = x[i];
                    n += 1;
                }
                Op::Neg => st[n - 1] = -st[n - 1],
                Op::F1(f) => st[n - 1] = f(st[n - 1]),
                Op::Abs => st[n - 1] = st[n - 1].abs(),
                Op::Sgn => st[n - 1] = sgn(st[n - 1]),
                Op::AddV(i) => st[n - 1] += x[i],
                Op::SubV(i) => st[n - 1] -= x[i],
                Op::MulV(i) => st[n - 1] *= x[i],
                Op::DivV(i) => st[n - 1] /= x[i],
                Op::AddN(c) => st[n - 1] += c,
                Op::SubN(c) => st[n - 1] -= c,
                Op::MulN(c) => st[n - 1] *= c,
                Op::DivN(c) => st[n - 1] /= c,
                _ => {
                    n -= 1;
                    let (a, b) = (st[n - 1], st[n]);
                    st[n - 1] = match *op {
                        Op::Add => a + b,
                        Op::Sub => a - b,
                        Op::Mul => a * b,
                        Op::Div => a / b,
                        Op::Pow => a.powf(b),
                        Op::F2(f) => f(a, b),
                        _ => unreachable!("unary and leaf ops handled above"),
                    };
                }
            }
        }
        st[0]
    }
}

/// The postfix code of `text`, unfused.
fn parse(text: &str, vars: &[&str]) -> Result<Vec<Op>, ExprError> {
    let mut p = Parser {
        s: text.as_bytes(),
        at: 0,
        vars,
        code: Vec::new(),
        nest: 0,
    };
    p.expr()?;
    p.skip_space();
    if p.at < p.s.len() {
        return Err(p.syntax("unexpected character"));
    }
    if depth(&p.code) > MAX_DEPTH {
        return Err(ExprError::Syntax {
            what: format!("nested more than {MAX_DEPTH} deep"),
            column: 1,
        });
    }
    Ok(p.code)
}

struct Parser<'a> {
    s: &'a [u8],
    at: usize,
    vars: &'a [&'a str],
    code: Vec<Op>,
    /// Parentheses and signs open: bounded, so that a hostile file cannot
    /// overflow the parser's stack.
    nest: usize,
}

impl Parser<'_> {
    fn syntax(&self, what: &str) -> ExprError {
        ExprError::Syntax {
            what: what.to_string(),
            column: self.at + 1,
        }
    }

    fn skip_space(&mut self) {
        while self.at < self.s.len() && self.s[self.at].is_ascii_whitespace() {
            self.at += 1;
        }
    }

    fn eat(&mut self, c: u8) -> bool {
        self.skip_space();
        if self.s.get(self.at) == Some(&c) {
            self.at += 1;
            true
        } else {
            false
        }
    }

    fn expr(&mut self) -> Result<(), ExprError> {
        self.term()?;
        loop {
            if self.eat(b'+') {
                self.term()?;
                self.code.push(Op::Add);
            } else if self.eat(b'-') {
                self.term()?;
                self.code.push(Op::Sub);
            } else {
                return Ok(());
            }
        }
    }

    fn term(&mut self) -> Result<(), ExprError> {
        self.unary()?;
        loop {
            if self.eat(b'*') {
                self.unary()?;
                self.code.push(Op::Mul);
            } else if self.eat(b'/') {
                self.unary()?;
                self.code.push(Op::Div);
            } else {
                return Ok(());
            }
        }
    }

    fn unary(&mut self) -> Result<(), ExprError> {
        self.nest += 1;
        if self.nest > 2 * MAX_DEPTH {
            return Err(self.syntax(&format!("nested more than {} deep", 2 * MAX_DEPTH)));
        }
        let r = self.unary_inner();
        self.nest -= 1;
        r
    }

    fn unary_inner(&mut self) -> Result<(), ExprError> {
        if self.eat(b'-') {
            self.unary()?;
            self.code.push(Op::Neg);
            return Ok(());
        }
        self.eat(b'+');
        self.atom()?;
        if self.eat(b'^') {
            self.unary()?;
            self.code.push(Op::Pow);
        }
        Ok(())
    }

    fn atom(&mut self) -> Result<(), ExprError> {
        self.skip_space();
        let start = self.at;
        let Some(&c) = self.s.get(self.at) else {
            return Err(self.syntax("expression ends too early"));
        };
        if self.eat(b'(') {
            self.expr()?;
            if !self.eat(b')') {
                return Err(self.syntax("expected `)`"));
            }
            return Ok(());
        }
        if c.is_ascii_digit() || c == b'.' {
            return self.number();
        }
        if !(c.is_ascii_alphabetic() || c == b'_') {
            return Err(self.syntax(&format!("unexpected `{}`", c as char)));
        }
        while self
            .s
            .get(self.at)
            .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
        {
            self.at += 1;
        }
        let name = std::str::from_utf8(&self.s[start..self.at]).unwrap_or_default();
        if self.eat(b'(') {
            return self.call(name, start);
        }
        match self.vars.iter().position(|v| *v == name) {
            Some(i) => {
                self.code.push(Op::Var(i));
                Ok(())
            }
            None => Err(ExprError::Unknown {
                name: name.to_string(),
                column: start + 1,
                known: self.vars.join(", "),
            }),
        }
    }

    fn call(&mut self, name: &str, start: usize) -> Result<(), ExprError> {
        let mut args = 0;
        loop {
            self.expr()?;
            args += 1;
            if self.eat(b')') {
                break;
            }
            if !self.eat(b',') {
                return Err(self.syntax("expected `,` or `)`"));
            }
        }
        let op =
            match (args, function1(name), function2(name)) {
                (1, Some(_), _) if name == "abs" => Op::Abs,
                (1, Some(_), _) if name == "sgn" => Op::Sgn,
                (1, Some(f), _) => Op::F1(f),
                (2, _, Some(f)) => Op::F2(f),
                (_, None, None) => return Err(ExprError::Unknown {
                    name: format!("{name}()"),
                    column: start + 1,
                    known:
                        "abs, sqrt, exp, ln, sin, cos, tan, tanh, atan, sgn, min, max, pow, atan2"
                            .into(),
                }),
                _ => {
                    return Err(ExprError::Syntax {
                        what: format!(
                            "`{name}` takes {} argument(s), not {args}",
                            if function1(name).is_some() { 1 } else { 2 }
                        ),
                        column: start + 1,
                    })
                }
            };
        self.code.push(op);
        Ok(())
    }

    fn number(&mut self) -> Result<(), ExprError> {
        let start = self.at;
        let digits = |p: &mut Self| {
            while p.s.get(p.at).is_some_and(|c| c.is_ascii_digit()) {
                p.at += 1;
            }
        };
        digits(self);
        if self.s.get(self.at) == Some(&b'.') {
            self.at += 1;
            digits(self);
        }
        if matches!(self.s.get(self.at), Some(b'e' | b'E')) {
            self.at += 1;
            if matches!(self.s.get(self.at), Some(b'+' | b'-')) {
                self.at += 1;
            }
            digits(self);
        }
        let text = std::str::from_utf8(&self.s[start..self.at]).unwrap_or_default();
        match text.parse::<f64>() {
            Ok(v) => {
                self.code.push(Op::Num(v));
                Ok(())
            }
            Err(_) => Err(ExprError::Syntax {
                what: format!("`{text}` is not a number"),
                column: start + 1,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(s: &str, vars: &[&str], x: &[f64]) -> f64 {
        Expr::compile(s, vars).unwrap().eval(x)
    }

    #[test]
    fn precedence_and_associativity_follow_arithmetic() {
        assert_eq!(eval("1 + 2 * 3", &[], &[]), 7.0);
        assert_eq!(eval("(1 + 2) * 3", &[], &[]), 9.0);
        assert_eq!(eval("8 / 4 / 2", &[], &[]), 1.0);
        assert_eq!(eval("2 ^ 3 ^ 2", &[], &[]), 512.0);
        assert_eq!(eval("-2 ^ 2", &[], &[]), -4.0);
        assert_eq!(eval("2 ^ -1", &[], &[]), 0.5);
        assert_eq!(eval("10 - 4 - 3", &[], &[]), 3.0);
        assert_eq!(eval("1.5e-3 * 2E3", &[], &[]), 3.0);
        assert_eq!(eval("--3", &[], &[]), 3.0);
    }

    /// The closures and the fused code compute what the parser's code
    /// computes, to the bit, on expressions with every fused operation, on
    /// values of both signs, zeros and magnitudes far apart.
    #[test]
    fn fused_code_is_the_parsed_code_to_the_bit() {
        let vars = ["u", "v", "q", "c"];
        let texts = [
            "c * abs(v) * v + 2.5 * sgn(v) - u / 0.01",
            "(v - abs(v) * q) / 0.004 - u * c + 1e-3 / u",
            "c * (u - q) - v * 3 + (u + 0.5) * (v - 0.25) / (q + 2)",
            "-u * -v - sgn(-q) * 7 + pow(abs(u), 1.5) * c / 3",
            "max(u, v) * 2 - min(q, c) / v + exp(-abs(v) / 0.03) * c",
            "u ^ 2 * v - 4 - c + q * q * q / 1.7",
        ];
        let values: [f64; 8] = [-3.7, -1e-9, -0.0, 0.0, 2e-7, 0.3, 1.0, 42.0];
        let mut checked = 0;
        for text in texts {
            let fused = Expr::compile(text, &vars).unwrap();
            let plain = Expr {
                code: parse(text, &vars).unwrap(),
                text: text.to_string(),
                tree: None,
            };
            assert!(fused.tree.is_some(), "{text}: no closures");
            assert!(fused.code.len() < plain.code.len(), "{text}: nothing fused");
            for (i, &a) in values.iter().enumerate() {
                for &b in &values[i..] {
                    let x = [a, b, 0.5 * a - b, b.abs() + 0.1];
                    // The closures, the fused code, the parser's code.
                    let (f, s, p) = (fused.eval(&x), fused.run(&x), plain.eval(&x));
                    for (name, y) in [("closures", f), ("fused code", s)] {
                        assert!(
                            y.to_bits() == p.to_bits() || (y.is_nan() && p.is_nan()),
                            "{text} at {x:?}: {name} {y} against {p}"
                        );
                    }
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 6 * 36);
    }

    /// Code longer than [`TREE_MAX`] runs on the stack machine.
    #[test]
    fn a_long_chain_of_terms_runs_on_the_stack_machine() {
        let text = vec!["u * 2"; 200].join(" + ");
        let e = Expr::compile(&text, &["u"]).unwrap();
        assert!(e.tree.is_none());
        assert_eq!(e.eval(&[0.5]), 200.0);
        assert!(Expr::compile("u * 2 + u", &["u"]).unwrap().tree.is_some());
    }

    #[test]
    fn variables_and_functions() {
        let v = ["u", "v", "tau_m"];
        let x = [0.3, -2.0, 0.5];
        assert_eq!(eval("u / tau_m", &v, &x), 0.6);
        assert_eq!(eval("abs(v) + sgn(v)", &v, &x), 1.0);
        assert_eq!(eval("max(u, tau_m) - min(u, v)", &v, &x), 2.5);
        assert_eq!(eval("pow(2, 10)", &v, &x), 1024.0);
        assert!((eval("exp(ln(3))", &v, &x) - 3.0).abs() < 1e-15);
        assert!((eval("atan2(1, 1) * 4", &v, &x) - std::f64::consts::PI).abs() < 1e-15);
    }

    #[test]
    fn errors_name_the_symbol_and_column() {
        let e = Expr::compile("u + 2 * qq", &["u", "q"]).unwrap_err();
        assert!(
            matches!(&e, ExprError::Unknown { name, column: 9, .. } if name == "qq"),
            "{e}"
        );
        assert!(e.to_string().contains("known: u, q"));
        let e = Expr::compile("foo(u)", &["u"]).unwrap_err();
        assert!(e.to_string().contains("`foo()`"), "{e}");
        let e = Expr::compile("min(u)", &["u"]).unwrap_err();
        assert!(e.to_string().contains("takes 2"), "{e}");
        for bad in ["", "u +", "(u", "u )", "2 $ u", "1..2"] {
            assert!(Expr::compile(bad, &["u"]).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn deep_nesting_is_refused_not_overflowed() {
        let deep = format!("{}1{}", "(1 + ".repeat(40), ")".repeat(40));
        assert!(Expr::compile(&deep, &[]).is_err());
        let ok = format!("{}1{}", "(1 + ".repeat(20), ")".repeat(20));
        assert_eq!(eval(&ok, &[], &[]), 21.0);
        let hostile = format!("{}1{}", "(".repeat(100_000), ")".repeat(100_000));
        assert!(Expr::compile(&hostile, &[]).is_err());
        assert!(Expr::compile(&"-".repeat(100_000), &[]).is_err());
    }
}
