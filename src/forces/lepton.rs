//! OpenSim's Lepton expressions (ExpressionBasedCoordinateForce,
//! opensim-semantics.md §8.2), evaluated with `evalexpr`.
//!
//! Lepton's grammar differs from evalexpr's in ways that change results:
//! `^` is right-associative in Lepton (`2^3^2` = 512) but left-associative in
//! evalexpr; unary minus binds between `*` and `^` in Lepton
//! (`-q^2` = −(q²), `-q*2` = (−q)·2); and evalexpr computes `1/2` in integers.
//! So the expression is parsed here with Lepton's rules (a precedence-climbing
//! parser following `Vendors/lepton/src/Parser.cpp`: operator precedences
//! `+ -` 0, `* /` 1, unary minus 2, `^` 3; sub-expression definitions
//! `expr; a=…; b=…` inlined, each definition able to use those written after
//! it) and re-emitted as a fully parenthesised evalexpr expression whose
//! numbers are all floats and whose functions are Lepton's, with Lepton's
//! definitions (`step(x)` = 1 for x ≥ 0, `delta(x)` = 1 for x = 0, …). That
//! string is compiled once with [`evalexpr::build_operator_tree`] and
//! evaluated with a small stack-allocated context holding `q` and `qdot`:
//! at load, where it must agree with the parsed tree, and in the tests,
//! which hold the two to the same bits on every expression. Per frame the
//! parsed tree itself is evaluated (`Expression::eval`): evalexpr collects
//! each operator's arguments in a fresh vector, a few allocations per call,
//! and a frame of static optimization allocates nothing
//! (tests/allocations.rs).
//!
//! Not reproduced: Lepton's `optimize()` algebraic rewrites (constant
//! folding, `0*x` → 0, `x-x` → 0, merged constant factors). They change
//! results only in the last bits, or where `x` is NaN or infinite.

use evalexpr::{
    error::EvalexprResultValue, Context, DefaultNumericTypes, EvalexprError, EvalexprResult, Node,
    Value,
};

/// A compiled Lepton expression in the variables `q` and `qdot`.
#[derive(Debug, Clone)]
pub struct Expression {
    /// The expression as given (whitespace removed, as OpenSim does).
    pub source: String,
    /// The evalexpr translation (for diagnostics).
    pub translated: String,
    tree: Node<DefaultNumericTypes>,
    ast: Ast,
    /// The parsed tree in postfix order, one contiguous program ([`Self::eval`]
    /// runs it on a stack of [`STACK`] values; empty when it needs more, and
    /// the tree is walked instead): a sweep evaluates thousands of
    /// expressions per frame, and a tree's boxed nodes, scattered in memory,
    /// are fetched one after the other.
    program: Vec<Op>,
}

/// One instruction of [`Expression::program`]: pushes a value, or replaces
/// the top one or two.
#[derive(Debug, Clone, Copy)]
enum Op {
    Num(f64),
    Var(Var),
    Neg,
    Bin(BinOp),
    Call1(Func),
    Call2(Func),
}

/// The stack depth [`Expression::program`] is limited to.
const STACK: usize = 16;

/// `a` in postfix order into `out`; returns the stack depth it needs.
fn postfix(a: &Ast, out: &mut Vec<Op>) -> usize {
    match a {
        Ast::Num(v) => {
            out.push(Op::Num(*v));
            1
        }
        Ast::Var(v) => {
            out.push(Op::Var(*v));
            1
        }
        Ast::Neg(x) => {
            let d = postfix(x, out);
            out.push(Op::Neg);
            d
        }
        Ast::Bin(op, x, y) => {
            let dx = postfix(x, out);
            let dy = postfix(y, out);
            out.push(Op::Bin(*op));
            dx.max(1 + dy)
        }
        Ast::Call(f, args) => {
            // As the tree walk: two arguments, or the first.
            if args.len() == 2 {
                let dx = postfix(&args[0], out);
                let dy = postfix(&args[1], out);
                out.push(Op::Call2(*f));
                dx.max(1 + dy)
            } else {
                let d = postfix(&args[0], out);
                out.push(Op::Call1(*f));
                d
            }
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Func {
    Sqrt,
    Exp,
    Log,
    Sin,
    Cos,
    Sec,
    Csc,
    Tan,
    Cot,
    Asin,
    Acos,
    Atan,
    Sinh,
    Cosh,
    Tanh,
    Erf,
    Erfc,
    Step,
    Delta,
    Square,
    Cube,
    Recip,
    Min,
    Max,
    Abs,
}

const FUNCS: &[(&str, Func)] = &[
    ("sqrt", Func::Sqrt),
    ("exp", Func::Exp),
    ("log", Func::Log),
    ("sin", Func::Sin),
    ("cos", Func::Cos),
    ("sec", Func::Sec),
    ("csc", Func::Csc),
    ("tan", Func::Tan),
    ("cot", Func::Cot),
    ("asin", Func::Asin),
    ("acos", Func::Acos),
    ("atan", Func::Atan),
    ("sinh", Func::Sinh),
    ("cosh", Func::Cosh),
    ("tanh", Func::Tanh),
    ("erf", Func::Erf),
    ("erfc", Func::Erfc),
    ("step", Func::Step),
    ("delta", Func::Delta),
    ("square", Func::Square),
    ("cube", Func::Cube),
    ("recip", Func::Recip),
    ("min", Func::Min),
    ("max", Func::Max),
    ("abs", Func::Abs),
];

/// Prefix of the evalexpr function identifiers, so that evalexpr's own
/// builtins can never be picked by accident.
const FN_PREFIX: &str = "lepton_";

impl Func {
    fn name(self) -> &'static str {
        FUNCS
            .iter()
            .find(|(_, f)| *f == self)
            .map(|(n, _)| *n)
            .unwrap_or("?")
    }
    fn arity(self) -> usize {
        match self {
            Func::Min | Func::Max => 2,
            _ => 1,
        }
    }
    fn apply1(self, x: f64) -> f64 {
        match self {
            Func::Sqrt => x.sqrt(),
            Func::Exp => x.exp(),
            Func::Log => x.ln(),
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::Sec => 1.0 / x.cos(),
            Func::Csc => 1.0 / x.sin(),
            Func::Tan => x.tan(),
            Func::Cot => 1.0 / x.tan(),
            Func::Asin => x.asin(),
            Func::Acos => x.acos(),
            Func::Atan => x.atan(),
            Func::Sinh => x.sinh(),
            Func::Cosh => x.cosh(),
            Func::Tanh => x.tanh(),
            Func::Erf => erf(x),
            Func::Erfc => erfc(x),
            Func::Step => {
                if x >= 0.0 {
                    1.0
                } else {
                    0.0
                }
            }
            Func::Delta => {
                if x == 0.0 {
                    1.0
                } else {
                    0.0
                }
            }
            Func::Square => x * x,
            Func::Cube => x * x * x,
            Func::Recip => 1.0 / x,
            Func::Abs => x.abs(),
            Func::Min | Func::Max => f64::NAN,
        }
    }
    /// `std::min` / `std::max` semantics (first argument unless the second is
    /// strictly smaller / greater).
    fn apply2(self, a: f64, b: f64) -> f64 {
        match self {
            Func::Min => {
                if b < a {
                    b
                } else {
                    a
                }
            }
            Func::Max => {
                if a < b {
                    b
                } else {
                    a
                }
            }
            _ => f64::NAN,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Var {
    Q,
    Qdot,
}

#[derive(Debug, Clone)]
enum Ast {
    Num(f64),
    Var(Var),
    Neg(Box<Ast>),
    Bin(BinOp, Box<Ast>, Box<Ast>),
    Call(Func, Vec<Ast>),
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(String),
    Op(char),
    Ident(String),
    /// Function name (the token included its opening parenthesis).
    Func(String),
    LParen,
    RParen,
    Comma,
}

const OPERATORS: &str = "+-*/^";

/// Lepton's tokenizer (`Parser::getNextToken`), on whitespace-free text.
fn tokenize(s: &str) -> Result<Vec<Tok>, String> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i] as char;
        if c == '(' {
            out.push(Tok::LParen);
            i += 1;
        } else if c == ')' {
            out.push(Tok::RParen);
            i += 1;
        } else if c == ',' {
            out.push(Tok::Comma);
            i += 1;
        } else if OPERATORS.contains(c) {
            out.push(Tok::Op(c));
            i += 1;
        } else if c.is_ascii_whitespace() {
            i += 1;
        } else if c == '.' || c.is_ascii_digit() {
            let start = i;
            let mut found_decimal = c == '.';
            let mut found_exp = false;
            i += 1;
            while i < b.len() {
                let d = b[i] as char;
                if d.is_ascii_digit() {
                    i += 1;
                } else if d == '.' && !found_decimal {
                    found_decimal = true;
                    i += 1;
                } else if (d == 'e' || d == 'E') && !found_exp {
                    found_exp = true;
                    if i + 1 < b.len() && (b[i + 1] == b'-' || b[i + 1] == b'+') {
                        i += 1;
                    }
                    i += 1;
                } else {
                    break;
                }
            }
            out.push(Tok::Num(s[start..i].to_string()));
        } else {
            let start = i;
            let mut tok = None;
            while i < b.len() {
                let d = b[i] as char;
                if d == '(' {
                    tok = Some(Tok::Func(s[start..i].to_string()));
                    i += 1;
                    break;
                }
                if OPERATORS.contains(d) || d == ',' || d == ')' || d.is_ascii_whitespace() {
                    break;
                }
                i += 1;
            }
            out.push(tok.unwrap_or_else(|| Tok::Ident(s[start..i].to_string())));
        }
    }
    Ok(out)
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Num(s) | Tok::Ident(s) => s.clone(),
        Tok::Func(s) => format!("{s}("),
        Tok::Op(c) => c.to_string(),
        Tok::LParen => "(".into(),
        Tok::RParen => ")".into(),
        Tok::Comma => ",".into(),
    }
}

struct Parser<'a> {
    toks: &'a [Tok],
    pos: usize,
    defs: &'a [(String, Ast)],
}

impl Parser<'_> {
    /// `Parser::parsePrecedence`.
    fn parse(&mut self, precedence: u8) -> Result<Ast, String> {
        let tok = self
            .toks
            .get(self.pos)
            .ok_or("unexpected end of expression")?
            .clone();
        let mut result = match tok {
            Tok::Num(text) => {
                self.pos += 1;
                match text.parse::<f64>() {
                    Ok(v) if v.is_finite() => Ast::Num(v),
                    _ => return Err(format!("malformed number '{text}'")),
                }
            }
            Tok::Ident(name) => {
                self.pos += 1;
                // The most recent definition of a name wins (Lepton's map assignment).
                if let Some((_, def)) = self.defs.iter().rev().find(|(n, _)| *n == name) {
                    def.clone()
                } else {
                    match name.as_str() {
                        "q" => Ast::Var(Var::Q),
                        "qdot" => Ast::Var(Var::Qdot),
                        _ => {
                            return Err(format!(
                                "unknown variable '{name}' (an ExpressionBasedCoordinateForce expression may use only q and qdot)"
                            ))
                        }
                    }
                }
            }
            Tok::LParen => {
                self.pos += 1;
                let inner = self.parse(0)?;
                if self.toks.get(self.pos) != Some(&Tok::RParen) {
                    return Err("unbalanced parentheses".into());
                }
                self.pos += 1;
                inner
            }
            Tok::Func(name) => {
                self.pos += 1;
                let mut args = vec![self.parse(0)?];
                while self.toks.get(self.pos) == Some(&Tok::Comma) {
                    self.pos += 1;
                    args.push(self.parse(0)?);
                }
                if self.toks.get(self.pos) != Some(&Tok::RParen) {
                    return Err("unbalanced parentheses".into());
                }
                self.pos += 1;
                let f = FUNCS
                    .iter()
                    .find(|(n, _)| *n == name)
                    .map(|(_, f)| *f)
                    .ok_or_else(|| format!("unknown function '{name}'"))?;
                if args.len() != f.arity() {
                    return Err(format!(
                        "function '{name}' takes {} argument(s), found {}",
                        f.arity(),
                        args.len()
                    ));
                }
                Ast::Call(f, args)
            }
            Tok::Op('-') => {
                self.pos += 1;
                Ast::Neg(Box::new(self.parse(2)?))
            }
            other => return Err(format!("unexpected token '{}'", describe(&other))),
        };
        while let Some(Tok::Op(c)) = self.toks.get(self.pos) {
            let (op, prec, left) = match c {
                '+' => (BinOp::Add, 0, true),
                '-' => (BinOp::Sub, 0, true),
                '*' => (BinOp::Mul, 1, true),
                '/' => (BinOp::Div, 1, true),
                _ => (BinOp::Pow, 3, false),
            };
            if prec < precedence {
                return Ok(result);
            }
            self.pos += 1;
            let rhs = self.parse(if left { prec + 1 } else { prec })?;
            result = Ast::Bin(op, Box::new(result), Box::new(rhs));
        }
        Ok(result)
    }
}

fn parse_all(toks: &[Tok], defs: &[(String, Ast)]) -> Result<Ast, String> {
    let mut p = Parser { toks, pos: 0, defs };
    let ast = p.parse(0)?;
    if let Some(t) = toks.get(p.pos) {
        return Err(format!(
            "unexpected text '{}' at end of expression",
            describe(t)
        ));
    }
    Ok(ast)
}

/// Parse Lepton text (`Parser::parse`), with sub-expression definitions.
fn parse_lepton(text: &str) -> Result<Ast, String> {
    let mut primary = text;
    let mut subs = Vec::new();
    while let Some(p) = primary.rfind(';') {
        let sub = primary[p + 1..].trim();
        if !sub.is_empty() {
            subs.push(sub);
        }
        primary = &primary[..p];
    }
    // `subs` is last-first, the order in which Lepton parses the definitions.
    let mut defs: Vec<(String, Ast)> = Vec::new();
    for sub in subs {
        let eq = sub
            .find('=')
            .ok_or_else(|| format!("sub-expression '{sub}' does not specify a name"))?;
        let name = sub[..eq].trim();
        if name.is_empty() {
            return Err(format!("sub-expression '{sub}' does not specify a name"));
        }
        let toks = tokenize(&sub[eq + 1..])?;
        let ast =
            parse_all(&toks, &defs).map_err(|e| format!("in sub-expression '{name}': {e}"))?;
        defs.push((name.to_string(), ast));
    }
    let toks = tokenize(primary)?;
    parse_all(&toks, &defs)
}

/// Fully parenthesised evalexpr text; every number a float literal.
fn emit(ast: &Ast, out: &mut String) {
    match ast {
        Ast::Num(v) => {
            // `{:?}` always writes a float literal ("2.0", "1e-7"), which
            // evalexpr reads as a float, never as an integer.
            out.push('(');
            out.push_str(&format!("{v:?}"));
            out.push(')');
        }
        Ast::Var(Var::Q) => out.push('q'),
        Ast::Var(Var::Qdot) => out.push_str("qdot"),
        Ast::Neg(a) => {
            out.push_str("(-");
            emit(a, out);
            out.push(')');
        }
        Ast::Bin(op, a, b) => {
            out.push('(');
            emit(a, out);
            out.push(match op {
                BinOp::Add => '+',
                BinOp::Sub => '-',
                BinOp::Mul => '*',
                BinOp::Div => '/',
                BinOp::Pow => '^',
            });
            emit(b, out);
            out.push(')');
        }
        Ast::Call(f, args) => {
            out.push('(');
            out.push_str(FN_PREFIX);
            out.push_str(f.name());
            out.push('(');
            for (i, a) in args.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                emit(a, out);
            }
            out.push_str("))");
        }
    }
}

/// Evaluation context: the two variables, and Lepton's functions.
struct Ctx {
    q: Value<DefaultNumericTypes>,
    qdot: Value<DefaultNumericTypes>,
}

impl Context for Ctx {
    type NumericTypes = DefaultNumericTypes;

    fn get_value(&self, identifier: &str) -> Option<&Value> {
        match identifier {
            "q" => Some(&self.q),
            "qdot" => Some(&self.qdot),
            _ => None,
        }
    }

    fn call_function(&self, identifier: &str, argument: &Value) -> EvalexprResultValue {
        let f = identifier
            .strip_prefix(FN_PREFIX)
            .and_then(|n| FUNCS.iter().find(|(name, _)| *name == n))
            .map(|(_, f)| *f)
            .ok_or_else(|| EvalexprError::FunctionIdentifierNotFound(identifier.to_string()))?;
        if f.arity() == 2 {
            let args = argument.as_fixed_len_tuple(2)?;
            Ok(Value::Float(
                f.apply2(args[0].as_number()?, args[1].as_number()?),
            ))
        } else {
            Ok(Value::Float(f.apply1(argument.as_number()?)))
        }
    }

    fn are_builtin_functions_disabled(&self) -> bool {
        true
    }

    fn set_builtin_functions_disabled(&mut self, _disabled: bool) -> EvalexprResult<()> {
        Err(EvalexprError::ContextNotMutable)
    }
}

impl Expression {
    /// Compile Lepton text. All whitespace is removed first, as
    /// `ExpressionBasedCoordinateForce::extendConnectToModel` does. Errors
    /// (syntax, unknown function or variable) are returned as a message for
    /// the caller to locate.
    pub fn compile(text: &str) -> Result<Expression, String> {
        let source: String = text.chars().filter(|c| !c.is_whitespace()).collect();
        let ast = parse_lepton(&source)?;
        let mut translated = String::new();
        emit(&ast, &mut translated);
        let tree = evalexpr::build_operator_tree::<DefaultNumericTypes>(&translated)
            .map_err(|e| format!("cannot compile translated expression '{translated}': {e}"))?;
        let mut program = Vec::new();
        if postfix(&ast, &mut program) > STACK {
            program.clear();
        }
        let expr = Expression {
            source,
            translated,
            tree,
            ast,
            program,
        };
        // Evaluate once so that a translation problem shows at load time.
        let (a, b) = (expr.eval_evalexpr(0.0, 0.0)?, expr.eval(0.0, 0.0));
        if !(a == b || (a.is_nan() && b.is_nan())) {
            return Err(format!(
                "internal: '{}' evaluates to {b} but its translation '{}' to {a}",
                expr.source, expr.translated
            ));
        }
        Ok(expr)
    }

    /// The evalexpr translation's value (the reference for [`Self::eval`]).
    fn eval_evalexpr(&self, q: f64, qdot: f64) -> Result<f64, String> {
        let ctx = Ctx {
            q: Value::Float(q),
            qdot: Value::Float(qdot),
        };
        self.tree
            .eval_number_with_context(&ctx)
            .map_err(|e| format!("cannot evaluate '{}': {e}", self.source))
    }

    /// Value at coordinate value `q` and speed `qdot`: the parsed tree
    /// evaluated directly (no allocation), by its postfix program (the same
    /// operations in the same order as the tree walk, `eval_tree`).
    /// A NaN is reported downstream as a non-finite force.
    pub fn eval(&self, q: f64, qdot: f64) -> f64 {
        if self.program.is_empty() {
            return self.eval_tree(q, qdot);
        }
        let mut st = [0.0f64; STACK];
        let mut n = 0;
        for op in &self.program {
            match *op {
                Op::Num(v) => {
                    st[n] = v;
                    n += 1;
                }
                Op::Var(Var::Q) => {
                    st[n] = q;
                    n += 1;
                }
                Op::Var(Var::Qdot) => {
                    st[n] = qdot;
                    n += 1;
                }
                Op::Neg => st[n - 1] = -st[n - 1],
                Op::Bin(op) => {
                    n -= 1;
                    let (x, y) = (st[n - 1], st[n]);
                    st[n - 1] = match op {
                        BinOp::Add => x + y,
                        BinOp::Sub => x - y,
                        BinOp::Mul => x * y,
                        BinOp::Div => x / y,
                        BinOp::Pow => x.powf(y),
                    };
                }
                Op::Call1(f) => st[n - 1] = f.apply1(st[n - 1]),
                Op::Call2(f) => {
                    n -= 1;
                    st[n - 1] = f.apply2(st[n - 1], st[n]);
                }
            }
        }
        st[0]
    }

    /// [`Self::eval`] by walking the parsed tree.
    fn eval_tree(&self, q: f64, qdot: f64) -> f64 {
        fn ev(a: &Ast, q: f64, qd: f64) -> f64 {
            match a {
                Ast::Num(v) => *v,
                Ast::Var(Var::Q) => q,
                Ast::Var(Var::Qdot) => qd,
                Ast::Neg(x) => -ev(x, q, qd),
                Ast::Bin(op, x, y) => {
                    let (x, y) = (ev(x, q, qd), ev(y, q, qd));
                    match op {
                        BinOp::Add => x + y,
                        BinOp::Sub => x - y,
                        BinOp::Mul => x * y,
                        BinOp::Div => x / y,
                        BinOp::Pow => x.powf(y),
                    }
                }
                Ast::Call(f, args) => {
                    if args.len() == 2 {
                        f.apply2(ev(&args[0], q, qd), ev(&args[1], q, qd))
                    } else {
                        f.apply1(ev(&args[0], q, qd))
                    }
                }
            }
        }
        ev(&self.ast, q, qdot)
    }
}

/// The error function, to within a few ulp (tests: ≤ 1e-15 against libm): the series
/// erf x = (2/√π) e^{−x²} Σ (2x²)ⁿ x / (1·3·…·(2n+1)) (all terms positive)
/// for |x| ≤ 2, 1 − erfc x beyond.
pub fn erf(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    let a = x.abs();
    let v = if a <= 2.0 {
        let two_x2 = 2.0 * a * a;
        let mut term = a;
        let mut sum = a;
        let mut n = 0.0;
        while term > 1e-17 * sum {
            n += 1.0;
            term *= two_x2 / (2.0 * n + 1.0);
            sum += term;
        }
        2.0 / std::f64::consts::PI.sqrt() * (-a * a).exp() * sum
    } else {
        1.0 - erfc_cf(a)
    };
    v.copysign(x)
}

/// The complementary error function 1 − erf x, accurate in relative terms
/// for large x (continued fraction for x > 2).
pub fn erfc(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    if x > 2.0 {
        erfc_cf(x)
    } else if x < -2.0 {
        2.0 - erfc_cf(-x)
    } else {
        1.0 - erf(x)
    }
}

/// erfc x = e^{−x²}/√π · 1/(x + (1/2)/(x + 1/(x + (3/2)/(x + …)))), x > 0,
/// evaluated backwards from a fixed depth (ample for x > 2).
fn erfc_cf(x: f64) -> f64 {
    if x > 27.3 {
        return 0.0;
    }
    let mut f = x;
    for k in (1..=200).rev() {
        f = x + (k as f64 / 2.0) / f;
    }
    (-x * x).exp() / std::f64::consts::PI.sqrt() / f
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(s: &str, q: f64, qdot: f64) -> f64 {
        let e = Expression::compile(s).unwrap_or_else(|m| panic!("{s}: {m}"));
        let a = e.eval_evalexpr(q, qdot).unwrap();
        let b = e.eval(q, qdot);
        assert!(
            a == b || (a.is_nan() && b.is_nan()),
            "{s}: evalexpr {a} vs direct {b} ({})",
            e.translated
        );
        // The postfix program and the tree walk: the same bits.
        assert_eq!(b.to_bits(), e.eval_tree(q, qdot).to_bits(), "{s}");
        b
    }

    /// An expression deeper than the program's stack is evaluated by
    /// walking its tree; one within it by the program.
    #[test]
    fn deep_expressions_walk_the_tree() {
        let shallow = Expression::compile("-50*sqrt(1-0.91*sin(q+0.0873)^2)").unwrap();
        assert!(!shallow.program.is_empty());
        // q+(q+(q+...)): each level keeps one more value on the stack.
        let deep_text = format!("{}q{}", "q+(".repeat(STACK), ")".repeat(STACK));
        let deep = Expression::compile(&deep_text).unwrap();
        assert!(deep.program.is_empty());
        assert_eq!(ev(&deep_text, 0.5, 0.0), 0.5 * (STACK + 1) as f64);
        let right = format!("{}q{}", "q+(".repeat(STACK - 2), ")".repeat(STACK - 2));
        assert!(!Expression::compile(&right).unwrap().program.is_empty());
        assert_eq!(ev(&right, 0.5, 0.0), 0.5 * (STACK - 1) as f64);
        for q in [-1.7, 0.0, 0.3, 2.2] {
            ev("-50*sqrt(1-0.91*sin(q+0.0873)^2)", q, 0.1);
            ev("max(q,qdot)*min(-q,2)/exp(-q^2)", q, -0.4);
        }
    }

    #[test]
    fn lepton_precedence() {
        // Unary minus binds between * and ^ (Lepton Parser.cpp: parsePrecedence(.., 2)).
        assert_eq!(ev("-q^2", 3.0, 0.0), -9.0);
        assert_eq!(ev("-2^2", 0.0, 0.0), -4.0);
        assert_eq!(ev("(-2)^2", 0.0, 0.0), 4.0);
        // ^ is right-associative: 2^(3^2) = 512, not (2^3)^2 = 64.
        assert_eq!(ev("2^3^2", 0.0, 0.0), 512.0);
        assert_eq!(ev("2^-1", 0.0, 0.0), 0.5);
        // Float division, never integer division.
        assert_eq!(ev("1/2", 0.0, 0.0), 0.5);
        assert_eq!(ev("7/2*2", 0.0, 0.0), 7.0);
        assert_eq!(ev("8/2/2", 0.0, 0.0), 2.0);
        assert_eq!(ev("1-2-3", 0.0, 0.0), -4.0);
        assert_eq!(ev("2*-q", 3.0, 0.0), -6.0);
        assert_eq!(ev("-q*2", 3.0, 0.0), -6.0);
        assert_eq!(ev("--q", 3.0, 0.0), 3.0);
        assert_eq!(ev("1 + 2 * 3 ^ 2", 0.0, 0.0), 19.0);
        assert_eq!(ev("q*qdot", 2.0, 5.0), 10.0);
    }

    #[test]
    fn numbers() {
        assert_eq!(ev("1e-7", 0.0, 0.0), 1e-7);
        assert_eq!(ev("2.5E+20*q", 1.0, 0.0), 2.5e20);
        assert_eq!(ev(".5", 0.0, 0.0), 0.5);
        assert_eq!(ev("3.", 0.0, 0.0), 3.0);
        assert_eq!(ev("0.1+0.2", 0.0, 0.0), 0.1 + 0.2);
        assert_eq!(ev("1e-3-q", 1.0, 0.0), 1e-3 - 1.0);
    }

    #[test]
    fn functions() {
        let q: f64 = 0.3;
        assert_eq!(ev("step(q-0.1)*(-50)", q, 0.0), -50.0);
        assert_eq!(ev("step(q-0.1)*(-50)", 0.05, 0.0), 0.0);
        assert_eq!(ev("step(q-0.3)", q, 0.0), 1.0); // x >= 0
        assert_eq!(ev("delta(q)", 0.0, 0.0), 1.0);
        assert_eq!(ev("delta(q)", 1e-300, 0.0), 0.0);
        assert_eq!(ev("square(q)+cube(q)", 2.0, 0.0), 12.0);
        assert_eq!(ev("recip(q)", 4.0, 0.0), 0.25);
        assert_eq!(ev("min(q,qdot)", 1.0, -2.0), -2.0);
        assert_eq!(ev("max(q, qdot)", 1.0, -2.0), 1.0);
        assert_eq!(ev("abs(-q)", 1.5, 0.0), 1.5);
        assert_eq!(ev("sec(q)", q, 0.0), 1.0 / q.cos());
        assert_eq!(ev("csc(q)", q, 0.0), 1.0 / q.sin());
        assert_eq!(ev("cot(q)", q, 0.0), 1.0 / q.tan());
        assert_eq!(ev("log(exp(q))", q, 0.0), q.exp().ln());
        assert_eq!(ev("sqrt(q)", 2.0, 0.0), 2f64.sqrt());
        assert_eq!(
            ev("sin(q)+cos(q)+tan(q)+asin(q)+acos(q)+atan(q)", q, 0.0),
            q.sin() + q.cos() + q.tan() + q.asin() + q.acos() + q.atan()
        );
        assert_eq!(
            ev("sinh(q)*cosh(q)/tanh(q)", q, 0.0),
            q.sinh() * q.cosh() / q.tanh()
        );
        // A typical passive joint moment from OpenSim's example models.
        let s = "-1.5*exp(-10*(q-0.5))+1.5*exp(10*(-q-0.5)) - 0.1*qdot";
        let (qq, qd) = (0.2_f64, -0.7_f64);
        let want = -1.5 * (-10.0 * (qq - 0.5)).exp() + 1.5 * (10.0 * (-qq - 0.5)).exp() - 0.1 * qd;
        assert!((ev(s, qq, qd) - want).abs() <= 1e-12 * want.abs());
    }

    #[test]
    fn erf_values() {
        // Reference values: CPython math.erf / math.erfc (C libm).
        let cases = [
            (0.5, 0.5204998778130465, 0.4795001221869535),
            (1.0, 0.8427007929497149, 0.15729920705028513),
            (2.0, 0.9953222650189527, 0.004677734981047265),
            (2.01, 0.9955248493552482, 0.004475150644751763),
            (2.5, 0.999593047982555, 0.0004069520174449589),
            (3.0, 0.9999779095030014, 2.2090496998585438e-05),
            (4.0, 0.9999999845827421, 1.541725790028002e-08),
            (-1.3, -0.9340079449406524, 1.9340079449406524),
        ];
        for (x, e, ec) in cases {
            assert!((erf(x) - e).abs() < 1e-15, "erf({x}) = {} vs {e}", erf(x));
            assert!(
                ((erfc(x) - ec) / ec).abs() < 1e-12,
                "erfc({x}) = {} vs {ec}",
                erfc(x)
            );
        }
        assert_eq!(erf(0.0), 0.0);
        assert_eq!(ev("erf(q)+erfc(q)", 0.7, 0.0), erf(0.7) + erfc(0.7));
    }

    #[test]
    fn sub_expressions() {
        assert_eq!(ev("a*q; a=3", 2.0, 0.0), 6.0);
        // A definition may use the ones written after it (parsed last-first).
        assert_eq!(ev("a+b; a=2*b; b=q^2", 3.0, 0.0), 27.0);
        assert_eq!(ev("k*(q-q0) ; k = -10 ; q0 = 0.5", 1.0, 0.0), -5.0);
        // A definition that uses one written before it is not defined yet.
        let e = Expression::compile("b; a=q; b=a").unwrap_err();
        assert!(e.contains("unknown variable 'a'"), "{e}");
        assert!(Expression::compile("q; =3")
            .unwrap_err()
            .contains("does not specify a name"));
        assert!(Expression::compile("q; a")
            .unwrap_err()
            .contains("does not specify a name"));
    }

    #[test]
    fn errors() {
        for (s, want) in [
            ("x*q", "unknown variable 'x'"),
            ("pi*q", "unknown variable 'pi'"),
            ("foo(q)", "unknown function 'foo'"),
            ("min(q)", "takes 2 argument"),
            ("sin(q,q)", "takes 1 argument"),
            ("(q", "unbalanced"),
            ("q)", "unexpected text"),
            ("", "unexpected end"),
            ("q*", "unexpected end"),
            ("2q", "unexpected text"),
            ("*q", "unexpected token"),
        ] {
            let e = Expression::compile(s).unwrap_err();
            assert!(e.contains(want), "{s}: {e}");
        }
    }
}
