//! Lexer and recursive-descent parser of the expression language.
//!
//! Grammar (Python's precedence: `**` binds tighter than unary minus on its
//! left and is right-associative, so `-u**2 = -(u**2)` and
//! `2**-u**2 = 2**(-(u**2))`):
//!
//! ```text
//! expr    := term (('+' | '-') term)*
//! term    := unary (('*' | '/') unary)*
//! unary   := ('-' | '+') unary | power
//! power   := atom ('**' unary)?
//! atom    := NUMBER | NAME | NAME '(' expr (',' expr)* ')' | '(' expr ')'
//! ```
//!
//! Columns are 1-based character positions in the expression string.

use crate::error::{FcolError, Result};

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(f64),
    Name(String),
    Plus,
    Minus,
    Star,
    Slash,
    Pow,
    LParen,
    RParen,
    Comma,
    End,
}

#[derive(Debug, Clone)]
struct Token {
    tok: Tok,
    col: usize,
}

fn err(expr: &str, col: usize, msg: impl Into<String>) -> FcolError {
    FcolError::Expression {
        expr: expr.to_string(),
        col,
        msg: msg.into(),
    }
}

fn lex(src: &str) -> Result<Vec<Token>> {
    let chars: Vec<char> = src.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let col = i + 1;
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        if c.is_ascii_digit() || (c == '.' && i + 1 < chars.len() && chars[i + 1].is_ascii_digit())
        {
            let start = i;
            while i < chars.len() && chars[i].is_ascii_digit() {
                i += 1;
            }
            if i < chars.len() && chars[i] == '.' {
                i += 1;
                while i < chars.len() && chars[i].is_ascii_digit() {
                    i += 1;
                }
            }
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    while j < chars.len() && chars[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                } else {
                    return Err(err(
                        src,
                        i + 1,
                        "malformed number: the exponent needs digits (e.g. 1e-3)",
                    ));
                }
            }
            let text: String = chars[start..i].iter().collect();
            let x: f64 = text
                .parse()
                .map_err(|_| err(src, col, format!("malformed number {text:?}")))?;
            if i < chars.len() && (chars[i].is_alphabetic() || chars[i] == '_') {
                return Err(err(
                    src,
                    i + 1,
                    "a name cannot follow a number directly (write 2*u, not 2u)",
                ));
            }
            out.push(Token {
                tok: Tok::Num(x),
                col,
            });
            continue;
        }
        if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push(Token {
                tok: Tok::Name(chars[start..i].iter().collect()),
                col,
            });
            continue;
        }
        let tok = match c {
            '+' => Tok::Plus,
            '-' => Tok::Minus,
            '*' if i + 1 < chars.len() && chars[i + 1] == '*' => {
                i += 1;
                Tok::Pow
            }
            '*' => Tok::Star,
            '/' => Tok::Slash,
            '(' => Tok::LParen,
            ')' => Tok::RParen,
            ',' => Tok::Comma,
            '^' => return Err(err(src, col, "'^' is not a power: write u**2")),
            _ => return Err(err(src, col, format!("unexpected character {c:?}"))),
        };
        i += 1;
        out.push(Token { tok, col });
    }
    out.push(Token {
        tok: Tok::End,
        col: chars.len() + 1,
    });
    Ok(out)
}

/// Binary operators of the syntax tree.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
}

/// The syntax tree; names are resolved by the compiler (which reports
/// unknown ones at their column).
#[derive(Debug, Clone, PartialEq)]
pub enum Ast {
    Num(f64),
    Name(String, usize),
    Neg(Box<Ast>),
    Bin(BinOp, Box<Ast>, Box<Ast>),
    Call(String, Vec<Ast>, usize),
}

struct Parser<'a> {
    src: &'a str,
    toks: Vec<Token>,
    pos: usize,
}

impl Parser<'_> {
    fn peek(&self) -> &Tok {
        &self.toks[self.pos].tok
    }
    fn col(&self) -> usize {
        self.toks[self.pos].col
    }
    fn bump(&mut self) -> Token {
        let t = self.toks[self.pos].clone();
        if self.pos + 1 < self.toks.len() {
            self.pos += 1;
        }
        t
    }
    fn expr(&mut self) -> Result<Ast> {
        let mut lhs = self.term()?;
        loop {
            let op = match self.peek() {
                Tok::Plus => BinOp::Add,
                Tok::Minus => BinOp::Sub,
                _ => return Ok(lhs),
            };
            self.bump();
            let rhs = self.term()?;
            lhs = Ast::Bin(op, Box::new(lhs), Box::new(rhs));
        }
    }
    fn term(&mut self) -> Result<Ast> {
        let mut lhs = self.unary()?;
        loop {
            let op = match self.peek() {
                Tok::Star => BinOp::Mul,
                Tok::Slash => BinOp::Div,
                _ => return Ok(lhs),
            };
            self.bump();
            let rhs = self.unary()?;
            lhs = Ast::Bin(op, Box::new(lhs), Box::new(rhs));
        }
    }
    fn unary(&mut self) -> Result<Ast> {
        match self.peek() {
            Tok::Minus => {
                self.bump();
                Ok(Ast::Neg(Box::new(self.unary()?)))
            }
            Tok::Plus => {
                self.bump();
                self.unary()
            }
            _ => self.power(),
        }
    }
    fn power(&mut self) -> Result<Ast> {
        let base = self.atom()?;
        if *self.peek() == Tok::Pow {
            self.bump();
            let exp = self.unary()?;
            return Ok(Ast::Bin(BinOp::Pow, Box::new(base), Box::new(exp)));
        }
        Ok(base)
    }
    fn atom(&mut self) -> Result<Ast> {
        let t = self.bump();
        match t.tok {
            Tok::Num(x) => Ok(Ast::Num(x)),
            Tok::Name(name) => {
                if *self.peek() == Tok::LParen {
                    self.bump();
                    let mut args = Vec::new();
                    if *self.peek() == Tok::RParen {
                        return Err(err(
                            self.src,
                            self.col(),
                            format!("{name}() needs an argument"),
                        ));
                    }
                    loop {
                        args.push(self.expr()?);
                        match self.peek() {
                            Tok::Comma => {
                                self.bump();
                            }
                            Tok::RParen => {
                                self.bump();
                                break;
                            }
                            _ => {
                                return Err(err(
                                    self.src,
                                    self.col(),
                                    format!("expected ',' or ')' in the arguments of {name}"),
                                ))
                            }
                        }
                    }
                    Ok(Ast::Call(name, args, t.col))
                } else {
                    Ok(Ast::Name(name, t.col))
                }
            }
            Tok::LParen => {
                let inner = self.expr()?;
                if *self.peek() != Tok::RParen {
                    return Err(err(
                        self.src,
                        self.col(),
                        format!("expected ')' to match the '(' of column {}", t.col),
                    ));
                }
                self.bump();
                Ok(inner)
            }
            Tok::End => Err(err(self.src, t.col, "unexpected end of expression")),
            Tok::RParen => Err(err(self.src, t.col, "unexpected ')'")),
            Tok::Comma => Err(err(self.src, t.col, "unexpected ','")),
            Tok::Pow | Tok::Star | Tok::Slash => Err(err(
                self.src,
                t.col,
                "expected a number, a name or '(' before this operator",
            )),
            Tok::Plus | Tok::Minus => unreachable!("handled by unary"),
        }
    }
}

/// Parse an expression into its syntax tree.
pub fn parse(src: &str) -> Result<Ast> {
    let toks = lex(src)?;
    if toks.len() == 1 {
        return Err(err(src, 1, "empty expression"));
    }
    let mut p = Parser { src, toks, pos: 0 };
    let ast = p.expr()?;
    match p.peek() {
        Tok::End => Ok(ast),
        Tok::RParen => Err(err(src, p.col(), "unmatched ')'")),
        _ => Err(err(
            src,
            p.col(),
            "expected an operator (+ - * / **) or the end of the expression",
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn col_of(src: &str) -> usize {
        match parse(src) {
            Err(FcolError::Expression { col, .. }) => col,
            other => panic!("expected an error for {src:?}, got {other:?}"),
        }
    }

    #[test]
    fn precedence() {
        use Ast::*;
        let n = |x| Box::new(Num(x));
        assert_eq!(
            parse("-2**2").unwrap(),
            Neg(Box::new(Bin(BinOp::Pow, n(2.0), n(2.0))))
        );
        assert_eq!(
            parse("2**3**2").unwrap(),
            Bin(
                BinOp::Pow,
                n(2.0),
                Box::new(Bin(BinOp::Pow, n(3.0), n(2.0)))
            )
        );
        assert_eq!(
            parse("1-2-3").unwrap(),
            Bin(
                BinOp::Sub,
                Box::new(Bin(BinOp::Sub, n(1.0), n(2.0))),
                n(3.0)
            )
        );
        assert_eq!(parse("1e-3").unwrap(), Num(1e-3));
        assert_eq!(parse(".5").unwrap(), Num(0.5));
    }

    #[test]
    fn error_columns() {
        assert_eq!(col_of("u +* v"), 4);
        assert_eq!(col_of("sin(u"), 6);
        assert_eq!(col_of("u $ v"), 3);
        assert_eq!(col_of("2u"), 2);
        assert_eq!(col_of("u)"), 2);
        assert_eq!(col_of("u^2"), 2);
        assert_eq!(col_of(""), 1);
        assert_eq!(col_of("1e"), 2);
        assert_eq!(col_of("(u+v"), 5);
    }
}
