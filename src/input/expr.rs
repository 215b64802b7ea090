//! Closed-form expressions of named inputs ("sin(x1) + 7*sin(x2)^2"), used by the analytic
//! `function` scenes that validate the study pipeline without a mechanism.
//!
//! Grammar: sums and differences of products and quotients of powers (`^`, right
//! associative, binding tighter than unary minus as in mathematics: `-x^2 = -(x^2)`) of
//! numbers, input names, `pi`, parenthesised expressions and calls of `sin cos tan asin acos
//! atan exp ln log sqrt abs min max pow atan2`.

use std::fmt;

/// A parsed expression over inputs numbered in the order given to [`Expr::parse`], kept
/// as a postfix program: evaluating and dropping it never recurse, so a 200,000-term sum
/// costs memory, not stack.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    code: Vec<Instr>,
}

/// One postfix instruction: push a value, or replace the top operands by a result.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Instr {
    Number(f64),
    Input(usize),
    Neg,
    Binary(Op),
    Call(Func),
}

/// Nesting deeper than this (parentheses, unary signs, `^` chains, calls) is refused: the
/// parser recurses once per level, and no formula a person writes comes near it.
pub const MAX_DEPTH: usize = 256;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Func {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Exp,
    Ln,
    Sqrt,
    Abs,
    Min,
    Max,
    Pow,
    Atan2,
}

impl Func {
    fn arity(self) -> usize {
        match self {
            Func::Min | Func::Max | Func::Pow | Func::Atan2 => 2,
            _ => 1,
        }
    }

    fn parse(name: &str) -> Option<Func> {
        Some(match name {
            "sin" => Func::Sin,
            "cos" => Func::Cos,
            "tan" => Func::Tan,
            "asin" => Func::Asin,
            "acos" => Func::Acos,
            "atan" => Func::Atan,
            "exp" => Func::Exp,
            "ln" | "log" => Func::Ln,
            "sqrt" => Func::Sqrt,
            "abs" => Func::Abs,
            "min" => Func::Min,
            "max" => Func::Max,
            "pow" => Func::Pow,
            "atan2" => Func::Atan2,
            _ => return None,
        })
    }
}

/// A parse error with the character offset where it was found.
#[derive(Clone, Debug, PartialEq)]
pub struct ExprError {
    pub offset: usize,
    pub message: String,
}

impl fmt::Display for ExprError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (at character {})", self.message, self.offset + 1)
    }
}

struct Parser<'a> {
    text: &'a [u8],
    pos: usize,
    inputs: &'a [String],
    code: Vec<Instr>,
    depth: usize,
}

impl Parser<'_> {
    fn error<T>(&self, message: impl Into<String>) -> Result<T, ExprError> {
        Err(ExprError {
            offset: self.pos,
            message: message.into(),
        })
    }

    fn skip_space(&mut self) {
        while self.pos < self.text.len() && self.text[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
    }

    fn eat(&mut self, c: u8) -> bool {
        self.skip_space();
        if self.text.get(self.pos) == Some(&c) {
            self.pos += 1;
            true
        } else {
            false
        }
    }

    /// Enters one level of nesting, refusing to go past [`MAX_DEPTH`].
    fn nest(&mut self) -> Result<(), ExprError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return self.error(format!(
                "the expression is nested more than {MAX_DEPTH} levels deep (parentheses, signs, `^` or calls)"
            ));
        }
        Ok(())
    }

    fn sum(&mut self) -> Result<(), ExprError> {
        self.nest()?;
        self.product()?;
        loop {
            let op = if self.eat(b'+') {
                Op::Add
            } else if self.eat(b'-') {
                Op::Sub
            } else {
                self.depth -= 1;
                return Ok(());
            };
            self.product()?;
            self.code.push(Instr::Binary(op));
        }
    }

    fn product(&mut self) -> Result<(), ExprError> {
        self.unary()?;
        loop {
            let op = if self.eat(b'*') {
                Op::Mul
            } else if self.eat(b'/') {
                Op::Div
            } else {
                return Ok(());
            };
            self.unary()?;
            self.code.push(Instr::Binary(op));
        }
    }

    fn unary(&mut self) -> Result<(), ExprError> {
        // a run of signs is read in a loop: only its parity matters
        let mut negative = false;
        loop {
            if self.eat(b'-') {
                negative = !negative;
            } else if !self.eat(b'+') {
                break;
            }
        }
        self.power()?;
        if negative {
            self.code.push(Instr::Neg);
        }
        Ok(())
    }

    fn power(&mut self) -> Result<(), ExprError> {
        self.atom()?;
        if self.eat(b'^') {
            self.nest()?;
            self.unary()?;
            self.depth -= 1;
            self.code.push(Instr::Binary(Op::Pow));
        }
        Ok(())
    }

    fn atom(&mut self) -> Result<(), ExprError> {
        self.skip_space();
        let start = self.pos;
        let Some(&c) = self.text.get(self.pos) else {
            return self.error("unexpected end of the expression");
        };
        if self.eat(b'(') {
            self.sum()?;
            if !self.eat(b')') {
                return self.error("expected `)`");
            }
            return Ok(());
        }
        if c.is_ascii_digit() || c == b'.' {
            while self.pos < self.text.len() {
                let d = self.text[self.pos];
                let exponent_sign = (d == b'+' || d == b'-')
                    && matches!(self.text[self.pos - 1], b'e' | b'E')
                    && self.pos - 1 > start;
                if d.is_ascii_digit() || d == b'.' || d == b'e' || d == b'E' || exponent_sign {
                    self.pos += 1;
                } else {
                    break;
                }
            }
            let s = std::str::from_utf8(&self.text[start..self.pos]).expect("ASCII");
            return match s.parse::<f64>() {
                Ok(v) => {
                    self.code.push(Instr::Number(v));
                    Ok(())
                }
                Err(_) => {
                    self.pos = start;
                    self.error(format!("bad number `{s}`"))
                }
            };
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            while self.pos < self.text.len()
                && (self.text[self.pos].is_ascii_alphanumeric() || self.text[self.pos] == b'_')
            {
                self.pos += 1;
            }
            let name = std::str::from_utf8(&self.text[start..self.pos]).expect("ASCII");
            if let Some(i) = self.inputs.iter().position(|n| n == name) {
                self.code.push(Instr::Input(i));
                return Ok(());
            }
            if name == "pi" {
                self.code.push(Instr::Number(std::f64::consts::PI));
                return Ok(());
            }
            let Some(func) = Func::parse(name) else {
                self.pos = start;
                return self.error(format!(
                    "unknown name `{name}` (inputs: {}; constant: pi; functions: sin cos tan asin acos atan exp ln sqrt abs min max pow atan2)",
                    self.inputs.join(", ")
                ));
            };
            if !self.eat(b'(') {
                return self.error(format!("`{name}` is a function: write `{name}(...)`"));
            }
            self.sum()?;
            let mut args = 1;
            while self.eat(b',') {
                self.sum()?;
                args += 1;
            }
            if !self.eat(b')') {
                return self.error("expected `)` or `,`");
            }
            let arity = func.arity();
            if args != arity {
                self.pos = start;
                return self.error(format!("`{name}` takes {arity} argument(s), got {args}"));
            }
            self.code.push(Instr::Call(func));
            return Ok(());
        }
        self.error(format!("unexpected `{}`", c as char))
    }
}

impl Expr {
    /// Parses `text`; `inputs` are the names it may refer to.
    pub fn parse(text: &str, inputs: &[String]) -> Result<Expr, ExprError> {
        if !text.is_ascii() {
            let offset = text
                .char_indices()
                .find(|(_, c)| !c.is_ascii())
                .map_or(0, |(i, _)| i);
            return Err(ExprError {
                offset,
                message: "only ASCII characters are allowed".into(),
            });
        }
        let mut p = Parser {
            text: text.as_bytes(),
            pos: 0,
            inputs,
            code: Vec::new(),
            depth: 0,
        };
        p.sum()?;
        p.skip_space();
        if p.pos != p.text.len() {
            return p.error(format!("unexpected `{}`", p.text[p.pos] as char));
        }
        Ok(Expr { code: p.code })
    }

    /// The value at `x` (indexed like the `inputs` given to [`Expr::parse`]).
    pub fn eval(&self, x: &[f64]) -> f64 {
        let mut stack: Vec<f64> = Vec::with_capacity(8);
        for instr in &self.code {
            match *instr {
                Instr::Number(v) => stack.push(v),
                Instr::Input(i) => stack.push(x[i]),
                Instr::Neg => {
                    let a = stack.pop().expect("a parsed program");
                    stack.push(-a);
                }
                Instr::Binary(op) => {
                    let b = stack.pop().expect("a parsed program");
                    let a = stack.pop().expect("a parsed program");
                    stack.push(match op {
                        Op::Add => a + b,
                        Op::Sub => a - b,
                        Op::Mul => a * b,
                        Op::Div => a / b,
                        Op::Pow => pow(a, b),
                    });
                }
                Instr::Call(f) => {
                    let b = if f.arity() == 2 {
                        stack.pop().expect("a parsed program")
                    } else {
                        f64::NAN
                    };
                    let a = stack.pop().expect("a parsed program");
                    stack.push(match f {
                        Func::Sin => a.sin(),
                        Func::Cos => a.cos(),
                        Func::Tan => a.tan(),
                        Func::Asin => a.asin(),
                        Func::Acos => a.acos(),
                        Func::Atan => a.atan(),
                        Func::Exp => a.exp(),
                        Func::Ln => a.ln(),
                        Func::Sqrt => a.sqrt(),
                        Func::Abs => a.abs(),
                        Func::Min => a.min(b),
                        Func::Max => a.max(b),
                        Func::Pow => pow(a, b),
                        Func::Atan2 => a.atan2(b),
                    });
                }
            }
        }
        stack.pop().expect("a parsed program leaves one value")
    }
}

/// x^y with small whole exponents done by multiplication (exact and fast, and defined for
/// negative x).
fn pow(x: f64, y: f64) -> f64 {
    if y.fract() == 0.0 && y.abs() <= 16.0 {
        x.powi(y as i32)
    } else {
        x.powf(y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(text: &str, x: &[f64]) -> f64 {
        let names: Vec<String> = (1..=x.len()).map(|i| format!("x{i}")).collect();
        Expr::parse(text, &names).unwrap().eval(x)
    }

    #[test]
    fn precedence_and_associativity() {
        assert_eq!(eval("1 + 2 * 3", &[]), 7.0);
        assert_eq!(eval("(1 + 2) * 3", &[]), 9.0);
        assert_eq!(eval("2 ^ 3 ^ 2", &[]), 512.0);
        assert_eq!(eval("-x1^2", &[3.0]), -9.0);
        assert_eq!(eval("8 / 4 / 2", &[]), 1.0);
        assert_eq!(eval("10 - 4 - 3", &[]), 3.0);
        assert_eq!(eval("1.5e-3 * 2E+2", &[]), 0.3);
        assert_eq!(eval("max(x1, x2) - min(x1, x2)", &[2.0, -1.0]), 3.0);
    }

    #[test]
    fn ishigami_at_a_point() {
        let (x1, x2, x3) = (0.3_f64, -1.2_f64, 2.5_f64);
        let exact = x1.sin() + 7.0 * x2.sin().powi(2) + 0.1 * x3.powi(4) * x1.sin();
        let v = eval("sin(x1) + 7*sin(x2)^2 + 0.1*x3^4*sin(x1)", &[x1, x2, x3]);
        assert_eq!(v, exact);
    }

    #[test]
    fn errors_point_at_the_problem() {
        let names = vec!["x".to_string()];
        let e = Expr::parse("x + y", &names).unwrap_err();
        assert_eq!(e.offset, 4);
        assert!(e.message.contains("unknown name `y`"), "{}", e.message);
        assert!(Expr::parse("sin x", &names).is_err());
        assert!(Expr::parse("pow(x)", &names)
            .unwrap_err()
            .message
            .contains("2 argument"));
        assert!(Expr::parse("(x + 1", &names).is_err());
        assert!(Expr::parse("x 1", &names).is_err());
    }

    /// Inputs that used to overflow the stack and abort the process: deep nesting is an
    /// error at a position, long flat sums parse, evaluate and drop without recursion.
    #[test]
    fn no_input_overflows_the_stack() {
        let names = vec!["x".to_string()];
        let deep = format!("{}x{}", "(".repeat(10_000), ")".repeat(10_000));
        let e = Expr::parse(&deep, &names).unwrap_err();
        assert!(e.message.contains("nested more than 256"), "{e}");
        let chain = vec!["x"; 20_000].join("^");
        assert!(Expr::parse(&chain, &names).is_err());
        let calls = format!("{}x{}", "sin(".repeat(5_000), ")".repeat(5_000));
        assert!(Expr::parse(&calls, &names).is_err());
        // 100,000 unary minuses: an even count is x itself
        let signs = format!("{}x", "-".repeat(100_000));
        assert_eq!(Expr::parse(&signs, &names).unwrap().eval(&[2.5]), 2.5);
        assert_eq!(
            Expr::parse(&format!("-{signs}"), &names)
                .unwrap()
                .eval(&[2.5]),
            -2.5
        );
        // a 200,000-term sum: exact in f64 as long as the partial sums stay integers
        let sum = vec!["x"; 200_000].join(" + ");
        assert_eq!(Expr::parse(&sum, &names).unwrap().eval(&[3.0]), 600_000.0);
        // nesting up to the limit still parses
        let fine = format!("{}x{}", "(".repeat(200), ")".repeat(200));
        assert_eq!(Expr::parse(&fine, &names).unwrap().eval(&[1.5]), 1.5);
    }
}
