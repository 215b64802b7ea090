//! Closed-form expressions of named inputs ("sin(x1) + 7*sin(x2)^2"), used by the analytic
//! `function` scenes that validate the study pipeline without a mechanism.
//!
//! Grammar: sums and differences of products and quotients of powers (`^`, right
//! associative, binding tighter than unary minus as in mathematics: `-x^2 = -(x^2)`) of
//! numbers, input names, `pi`, parenthesised expressions and calls of `sin cos tan asin acos
//! atan exp ln log sqrt abs min max pow atan2`.

use std::fmt;

/// A parsed expression over inputs numbered in the order given to [`Expr::parse`].
#[derive(Clone, Debug, PartialEq)]
pub enum Expr {
    Number(f64),
    Input(usize),
    Neg(Box<Expr>),
    Binary(Op, Box<Expr>, Box<Expr>),
    Call(Func, Vec<Expr>),
}

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
    fn parse(name: &str) -> Option<(Func, usize)> {
        Some(match name {
            "sin" => (Func::Sin, 1),
            "cos" => (Func::Cos, 1),
            "tan" => (Func::Tan, 1),
            "asin" => (Func::Asin, 1),
            "acos" => (Func::Acos, 1),
            "atan" => (Func::Atan, 1),
            "exp" => (Func::Exp, 1),
            "ln" | "log" => (Func::Ln, 1),
            "sqrt" => (Func::Sqrt, 1),
            "abs" => (Func::Abs, 1),
            "min" => (Func::Min, 2),
            "max" => (Func::Max, 2),
            "pow" => (Func::Pow, 2),
            "atan2" => (Func::Atan2, 2),
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

    fn sum(&mut self) -> Result<Expr, ExprError> {
        let mut left = self.product()?;
        loop {
            let op = if self.eat(b'+') {
                Op::Add
            } else if self.eat(b'-') {
                Op::Sub
            } else {
                return Ok(left);
            };
            left = Expr::Binary(op, Box::new(left), Box::new(self.product()?));
        }
    }

    fn product(&mut self) -> Result<Expr, ExprError> {
        let mut left = self.unary()?;
        loop {
            let op = if self.eat(b'*') {
                Op::Mul
            } else if self.eat(b'/') {
                Op::Div
            } else {
                return Ok(left);
            };
            left = Expr::Binary(op, Box::new(left), Box::new(self.unary()?));
        }
    }

    fn unary(&mut self) -> Result<Expr, ExprError> {
        if self.eat(b'-') {
            Ok(Expr::Neg(Box::new(self.unary()?)))
        } else if self.eat(b'+') {
            self.unary()
        } else {
            self.power()
        }
    }

    fn power(&mut self) -> Result<Expr, ExprError> {
        let base = self.atom()?;
        if self.eat(b'^') {
            let exponent = self.unary()?;
            Ok(Expr::Binary(Op::Pow, Box::new(base), Box::new(exponent)))
        } else {
            Ok(base)
        }
    }

    fn atom(&mut self) -> Result<Expr, ExprError> {
        self.skip_space();
        let start = self.pos;
        let Some(&c) = self.text.get(self.pos) else {
            return self.error("unexpected end of the expression");
        };
        if self.eat(b'(') {
            let e = self.sum()?;
            if !self.eat(b')') {
                return self.error("expected `)`");
            }
            return Ok(e);
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
                Ok(v) => Ok(Expr::Number(v)),
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
                return Ok(Expr::Input(i));
            }
            if name == "pi" {
                return Ok(Expr::Number(std::f64::consts::PI));
            }
            let Some((func, arity)) = Func::parse(name) else {
                self.pos = start;
                return self.error(format!(
                    "unknown name `{name}` (inputs: {}; constant: pi; functions: sin cos tan asin acos atan exp ln sqrt abs min max pow atan2)",
                    self.inputs.join(", ")
                ));
            };
            if !self.eat(b'(') {
                return self.error(format!("`{name}` is a function: write `{name}(...)`"));
            }
            let mut args = vec![self.sum()?];
            while self.eat(b',') {
                args.push(self.sum()?);
            }
            if !self.eat(b')') {
                return self.error("expected `)` or `,`");
            }
            if args.len() != arity {
                self.pos = start;
                return self.error(format!(
                    "`{name}` takes {arity} argument(s), got {}",
                    args.len()
                ));
            }
            return Ok(Expr::Call(func, args));
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
        };
        let e = p.sum()?;
        p.skip_space();
        if p.pos != p.text.len() {
            return p.error(format!("unexpected `{}`", p.text[p.pos] as char));
        }
        Ok(e)
    }

    /// The value at `x` (indexed like the `inputs` given to [`Expr::parse`]).
    pub fn eval(&self, x: &[f64]) -> f64 {
        match self {
            Expr::Number(v) => *v,
            Expr::Input(i) => x[*i],
            Expr::Neg(a) => -a.eval(x),
            Expr::Binary(op, a, b) => {
                let (a, b) = (a.eval(x), b.eval(x));
                match op {
                    Op::Add => a + b,
                    Op::Sub => a - b,
                    Op::Mul => a * b,
                    Op::Div => a / b,
                    Op::Pow => pow(a, b),
                }
            }
            Expr::Call(f, args) => {
                let a = args[0].eval(x);
                let b = || args[1].eval(x);
                match f {
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
                    Func::Min => a.min(b()),
                    Func::Max => a.max(b()),
                    Func::Pow => pow(a, b()),
                    Func::Atan2 => a.atan2(b()),
                }
            }
        }
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
}
