//! What tidy needs from one Rust source file, read with a real parser (`syn`): the line spans
//! of its test code, its functions, the module paths it names, its macro calls, environment
//! reads and error types, all outside tests.
//!
//! Test code is an item (a module, function, `use`, impl item, field, match arm, ...) under
//! `#[cfg(test)]` (or `#[cfg(all(test, ...))]`) or `#[test]`: it is skipped by its span, the rest
//! of the file is read. An out-of-line `#[cfg(test)] mod x;` is reported so that the caller can
//! skip the file of `x`. Macro bodies are token streams to `syn`; they are scanned token by
//! token for paths, nested macro calls and `env::var`.

use proc_macro2::{Spacing, Span, TokenStream, TokenTree};
use syn::spanned::Spanned;
use syn::visit::{self, Visit};
use syn::{Attribute, Fields, Item, UseTree};

/// A function outside tests.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Function {
    pub name: String,
    /// The line of its `fn` keyword.
    pub line: usize,
    /// Lines from the `fn` keyword to the closing brace, both included.
    pub lines: usize,
}

/// A path of the crate named outside tests (`crate::a::b`, `super::c`, `self::d`, a `use`
/// tree's leaves), made absolute from the crate root.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Reference {
    /// The module the path is written in (absolute).
    pub from: Vec<String>,
    /// The path (absolute, without `crate`).
    pub to: Vec<String>,
    pub line: usize,
}

/// The facts of one file (lines are 1-based; module paths are absolute, the crate root `[]`).
#[derive(Debug, Default)]
pub struct Facts {
    /// Inline modules `mod x { ... }` outside tests.
    pub inline_modules: Vec<Vec<String>>,
    /// Out-of-line test modules `#[cfg(test)] mod x;`.
    pub test_modules: Vec<Vec<String>>,
    /// Line spans (first, last) of test code.
    pub test_spans: Vec<(usize, usize)>,
    pub functions: Vec<Function>,
    pub references: Vec<Reference>,
    /// Macro calls: (the macro's name, the last segment of its path; line).
    pub macros: Vec<(String, usize)>,
    /// Lines of an `env::var(..)` / `env::var_os(..)` path.
    pub env_reads: Vec<usize>,
    /// Error types (`#[derive(Error)]`) whose message shows the field they return from
    /// `source()`: (`Type` or `Type::Variant`, the field, line).
    pub errors_showing_source: Vec<(String, String, usize)>,
    /// Enums that derive `Error` (outside tests): (name, line).
    pub error_enums: Vec<(String, usize)>,
}

/// The facts of `text`, the source of the module `module`.
pub fn read(text: &str, module: &[String]) -> syn::Result<Facts> {
    let file = syn::parse_file(text)?;
    let mut r = Reader {
        module: module.to_vec(),
        facts: Facts::default(),
    };
    if test_only(&file.attrs) {
        // `#![cfg(test)]`: the whole file.
        r.facts.test_spans.push((1, text.lines().count().max(1)));
    } else {
        r.visit_file(&file);
    }
    Ok(r.facts)
}

fn line(s: Span) -> usize {
    s.start().line
}

/// Whether `attrs` make their item test code: `#[test]`, `#[cfg(test)]`, `#[cfg(all(.., test, ..))]`.
pub fn test_only(attrs: &[Attribute]) -> bool {
    attrs.iter().any(|a| {
        if a.path().is_ident("test") {
            return true;
        }
        if !a.path().is_ident("cfg") {
            return false;
        }
        let Ok(list) = a.meta.require_list() else {
            return false;
        };
        let pred: String = list.tokens.to_string().split_whitespace().collect();
        pred == "test"
            || pred
                .strip_prefix("all(")
                .and_then(|p| p.strip_suffix(')'))
                .is_some_and(|p| p.split(',').any(|t| t == "test"))
    })
}

fn item_attrs(i: &Item) -> &[Attribute] {
    match i {
        Item::Const(x) => &x.attrs,
        Item::Enum(x) => &x.attrs,
        Item::ExternCrate(x) => &x.attrs,
        Item::Fn(x) => &x.attrs,
        Item::ForeignMod(x) => &x.attrs,
        Item::Impl(x) => &x.attrs,
        Item::Macro(x) => &x.attrs,
        Item::Mod(x) => &x.attrs,
        Item::Static(x) => &x.attrs,
        Item::Struct(x) => &x.attrs,
        Item::Trait(x) => &x.attrs,
        Item::TraitAlias(x) => &x.attrs,
        Item::Type(x) => &x.attrs,
        Item::Union(x) => &x.attrs,
        Item::Use(x) => &x.attrs,
        _ => &[],
    }
}

struct Reader {
    /// The module being read (absolute).
    module: Vec<String>,
    facts: Facts,
}

impl Reader {
    /// Records `node` as test code when `attrs` say so; `true` if it did (skip the node).
    fn skip_test(&mut self, attrs: &[Attribute], node: &impl Spanned) -> bool {
        if !test_only(attrs) {
            return false;
        }
        let s = node.span();
        self.facts.test_spans.push((line(s), s.end().line));
        true
    }

    fn function(&mut self, name: &syn::Ident, fn_token: Span, body: &syn::Block) {
        let first = line(fn_token);
        let last = line(body.brace_token.span.close());
        self.facts.functions.push(Function {
            name: name.to_string(),
            line: first,
            lines: last + 1 - first,
        });
    }

    /// Records a path given by its segments, when it starts at `crate`, `super` or `self`.
    fn reference(&mut self, segments: &[String], at: usize) {
        let mut base = self.module.clone();
        let rest = match segments.first().map(String::as_str) {
            Some("crate") => {
                base.clear();
                &segments[1..]
            }
            Some("self") => &segments[1..],
            Some("super") => {
                let ups = segments.iter().take_while(|s| *s == "super").count();
                base.truncate(base.len().saturating_sub(ups));
                &segments[ups..]
            }
            _ => return,
        };
        base.extend(rest.iter().cloned());
        self.facts.references.push(Reference {
            from: self.module.clone(),
            to: base,
            line: at,
        });
    }

    /// Scans a macro body: paths from `crate`/`super`/`self`, nested macro calls, `env::var`.
    fn tokens(&mut self, ts: TokenStream) {
        let t: Vec<TokenTree> = ts.into_iter().collect();
        let colons = |i: usize| {
            matches!((t.get(i), t.get(i + 1)),
                (Some(TokenTree::Punct(a)), Some(TokenTree::Punct(b)))
                    if a.as_char() == ':' && a.spacing() == Spacing::Joint && b.as_char() == ':')
        };
        let ident = |i: usize| match t.get(i) {
            Some(TokenTree::Ident(x)) => Some(x.to_string()),
            _ => None,
        };
        for (i, tt) in t.iter().enumerate() {
            match tt {
                TokenTree::Group(g) => self.tokens(g.stream()),
                TokenTree::Ident(x) => {
                    let name = x.to_string();
                    let bang = matches!(t.get(i + 1), Some(TokenTree::Punct(p)) if p.as_char() == '!')
                        && matches!(t.get(i + 2), Some(TokenTree::Group(_)));
                    if bang {
                        self.facts.macros.push((name.clone(), line(x.span())));
                    }
                    if name == "env"
                        && colons(i + 1)
                        && ident(i + 3).is_some_and(|v| v == "var" || v == "var_os")
                    {
                        self.facts.env_reads.push(line(x.span()));
                    }
                    let after_colons = i >= 2 && colons(i - 2);
                    if matches!(name.as_str(), "crate" | "super" | "self") && !after_colons {
                        let mut segs = vec![name];
                        let mut j = i + 1;
                        while colons(j) {
                            let Some(s) = ident(j + 2) else { break };
                            segs.push(s);
                            j += 3;
                        }
                        if segs.len() > 1 {
                            self.reference(&segs, line(x.span()));
                        }
                    }
                }
                _ => {}
            }
        }
    }

    /// Records an error type whose message shows the field it returns from `source()`.
    fn error_type(&mut self, name: String, attrs: &[Attribute], fields: &Fields, at: Span) {
        if let Some(field) = shown_source(attrs, fields) {
            self.facts
                .errors_showing_source
                .push((name, field, line(at)));
        }
    }
}

/// The leaves of a `use` tree, each as its path segments.
fn use_paths(prefix: &mut Vec<String>, tree: &UseTree, out: &mut Vec<Vec<String>>) {
    match tree {
        UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            use_paths(prefix, &p.tree, out);
            prefix.pop();
        }
        UseTree::Name(n) if n.ident == "self" => out.push(prefix.clone()),
        UseTree::Name(n) => out.push([prefix.as_slice(), &[n.ident.to_string()]].concat()),
        UseTree::Rename(r) => out.push([prefix.as_slice(), &[r.ident.to_string()]].concat()),
        UseTree::Glob(_) => out.push(prefix.clone()),
        UseTree::Group(g) => g.items.iter().for_each(|t| use_paths(prefix, t, out)),
    }
}

/// Whether `attrs` derive `Error` (thiserror's, by any path).
fn derives_error(attrs: &[Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("derive")
            && a.meta.require_list().is_ok_and(|l| {
                l.tokens
                    .clone()
                    .into_iter()
                    .any(|t| matches!(t, TokenTree::Ident(i) if i == "Error"))
            })
    })
}

/// The source field (`#[source]`, `#[from]` or named `source`) that the `#[error(...)]`
/// message of `attrs` also shows, if any (`#[error(transparent)]` shows none of its own).
fn shown_source(attrs: &[Attribute], fields: &Fields) -> Option<String> {
    let message = attrs.iter().find(|a| a.path().is_ident("error"))?;
    let tokens: Vec<TokenTree> = message
        .meta
        .require_list()
        .ok()?
        .tokens
        .clone()
        .into_iter()
        .collect();
    let key = fields.iter().enumerate().find_map(|(i, f)| {
        let marked = f
            .attrs
            .iter()
            .any(|a| a.path().is_ident("source") || a.path().is_ident("from"));
        match &f.ident {
            Some(n) if marked || n == "source" => Some(n.to_string()),
            None if marked => Some(i.to_string()),
            _ => None,
        }
    })?;
    let mut shows = false;
    for (i, t) in tokens.iter().enumerate() {
        match t {
            TokenTree::Literal(l) if i == 0 => {
                shows |= placeholders(&l.to_string()).contains(&key);
            }
            TokenTree::Ident(x) if *x == key => shows = true,
            TokenTree::Literal(l) if l.to_string() == key => {
                shows |= matches!(tokens.get(i.wrapping_sub(1)), Some(TokenTree::Punct(p)) if p.as_char() == '.');
            }
            TokenTree::Group(g) => {
                shows |= g.stream().into_iter().any(|t| match t {
                    TokenTree::Ident(x) => x == key,
                    _ => false,
                });
            }
            _ => {}
        }
    }
    shows.then_some(key)
}

/// The names of the `{name}` / `{name:...}` placeholders of a format string literal.
fn placeholders(lit: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = lit;
    while let Some(i) = rest.find('{') {
        rest = &rest[i + 1..];
        if let Some(r) = rest.strip_prefix('{') {
            rest = r; // `{{`
            continue;
        }
        let end = rest.find(['}', ':']).unwrap_or(rest.len());
        out.push(rest[..end].trim().to_string());
        rest = &rest[end..];
    }
    out
}

impl<'ast> Visit<'ast> for Reader {
    fn visit_item(&mut self, i: &'ast Item) {
        if self.skip_test(item_attrs(i), i) {
            if let Item::Mod(m) = i
                && m.content.is_none()
            {
                let mut path = self.module.clone();
                path.push(m.ident.to_string());
                self.facts.test_modules.push(path);
            }
            return;
        }
        if let Item::Mod(m) = i
            && let Some((_, items)) = &m.content
        {
            self.module.push(m.ident.to_string());
            self.facts.inline_modules.push(self.module.clone());
            for item in items {
                self.visit_item(item);
            }
            self.module.pop();
            return;
        }
        visit::visit_item(self, i);
    }

    fn visit_impl_item(&mut self, i: &'ast syn::ImplItem) {
        let attrs: &[Attribute] = match i {
            syn::ImplItem::Const(x) => &x.attrs,
            syn::ImplItem::Fn(x) => &x.attrs,
            syn::ImplItem::Type(x) => &x.attrs,
            syn::ImplItem::Macro(x) => &x.attrs,
            _ => &[],
        };
        if !self.skip_test(attrs, i) {
            visit::visit_impl_item(self, i);
        }
    }

    fn visit_trait_item(&mut self, i: &'ast syn::TraitItem) {
        let attrs: &[Attribute] = match i {
            syn::TraitItem::Const(x) => &x.attrs,
            syn::TraitItem::Fn(x) => &x.attrs,
            syn::TraitItem::Type(x) => &x.attrs,
            syn::TraitItem::Macro(x) => &x.attrs,
            _ => &[],
        };
        if !self.skip_test(attrs, i) {
            visit::visit_trait_item(self, i);
        }
    }

    fn visit_arm(&mut self, i: &'ast syn::Arm) {
        if !self.skip_test(&i.attrs, i) {
            visit::visit_arm(self, i);
        }
    }

    fn visit_field(&mut self, i: &'ast syn::Field) {
        if !self.skip_test(&i.attrs, i) {
            visit::visit_field(self, i);
        }
    }

    fn visit_field_value(&mut self, i: &'ast syn::FieldValue) {
        if !self.skip_test(&i.attrs, i) {
            visit::visit_field_value(self, i);
        }
    }

    fn visit_variant(&mut self, i: &'ast syn::Variant) {
        if !self.skip_test(&i.attrs, i) {
            visit::visit_variant(self, i);
        }
    }

    fn visit_local(&mut self, i: &'ast syn::Local) {
        if !self.skip_test(&i.attrs, i) {
            visit::visit_local(self, i);
        }
    }

    fn visit_stmt_macro(&mut self, i: &'ast syn::StmtMacro) {
        if !self.skip_test(&i.attrs, i) {
            visit::visit_stmt_macro(self, i);
        }
    }

    fn visit_item_fn(&mut self, i: &'ast syn::ItemFn) {
        self.function(&i.sig.ident, i.sig.fn_token.span, &i.block);
        visit::visit_item_fn(self, i);
    }

    fn visit_impl_item_fn(&mut self, i: &'ast syn::ImplItemFn) {
        self.function(&i.sig.ident, i.sig.fn_token.span, &i.block);
        visit::visit_impl_item_fn(self, i);
    }

    fn visit_trait_item_fn(&mut self, i: &'ast syn::TraitItemFn) {
        if let Some(body) = &i.default {
            self.function(&i.sig.ident, i.sig.fn_token.span, body);
        }
        visit::visit_trait_item_fn(self, i);
    }

    fn visit_item_enum(&mut self, i: &'ast syn::ItemEnum) {
        if derives_error(&i.attrs) {
            self.facts
                .error_enums
                .push((i.ident.to_string(), line(i.ident.span())));
            for v in &i.variants {
                let name = format!("{}::{}", i.ident, v.ident);
                self.error_type(name, &v.attrs, &v.fields, v.ident.span());
            }
        }
        visit::visit_item_enum(self, i);
    }

    fn visit_item_struct(&mut self, i: &'ast syn::ItemStruct) {
        if derives_error(&i.attrs) {
            self.error_type(i.ident.to_string(), &i.attrs, &i.fields, i.ident.span());
        }
        visit::visit_item_struct(self, i);
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        let segs: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
        let at = line(
            p.segments
                .first()
                .map_or_else(Span::call_site, |s| s.ident.span()),
        );
        if p.leading_colon.is_none() && segs.len() > 1 {
            self.reference(&segs, at);
        }
        if let [.., env, var] = segs.as_slice()
            && env == "env"
            && (var == "var" || var == "var_os")
        {
            self.facts.env_reads.push(at);
        }
        visit::visit_path(self, p);
    }

    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        if u.leading_colon.is_some() {
            return;
        }
        let mut paths = Vec::new();
        use_paths(&mut Vec::new(), &u.tree, &mut paths);
        for p in paths {
            self.reference(&p, line(u.use_token.span));
            if let [.., env, var] = p.as_slice()
                && env == "env"
                && (var == "var" || var == "var_os")
            {
                self.facts.env_reads.push(line(u.use_token.span));
            }
        }
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        if let Some(last) = m.path.segments.last() {
            self.facts
                .macros
                .push((last.ident.to_string(), line(last.ident.span())));
        }
        visit::visit_macro(self, m);
        self.tokens(m.tokens.clone());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn facts(text: &str, module: &[&str]) -> Facts {
        let m: Vec<String> = module.iter().map(|s| s.to_string()).collect();
        read(text, &m).unwrap()
    }

    #[test]
    fn test_code_is_skipped_by_its_span_and_the_rest_is_read() {
        let text = "\
#[cfg(test)]
use std::fmt;
fn a() {
    println!(\"a\");
}
#[cfg(all(test, feature = \"x\"))]
fn b() {
    println!(\"b\");
}
#[cfg(test)]
mod tests {
    fn c() {}
}
#[cfg(test)]
mod more;
fn d() {}
";
        let f = facts(text, &["m"]);
        assert_eq!(f.test_spans, [(1, 2), (6, 9), (10, 13), (14, 15)]);
        let names: Vec<_> = f
            .functions
            .iter()
            .map(|f| (f.name.as_str(), f.line, f.lines))
            .collect();
        assert_eq!(names, [("a", 3, 3), ("d", 16, 1)]);
        assert_eq!(f.macros, [("println".to_string(), 4)]);
        assert_eq!(f.test_modules, [vec!["m".to_string(), "more".to_string()]]);
    }

    #[test]
    fn references_are_made_absolute_from_crate_super_self_and_use_groups() {
        let text = "\
use crate::{a::{b, c}, d};
use super::e::F;
use self::g;
fn f() {
    super::super::h::i();
    format!(\"{}\", crate::j::k());
    std::env::var(\"X\");
}
mod inner {
    use super::l;
}
";
        let f = facts(text, &["p", "q"]);
        let to: Vec<(String, String)> = f
            .references
            .iter()
            .map(|r| (r.from.join("::"), r.to.join("::")))
            .collect();
        let want = [
            ("p::q", "a::b"),
            ("p::q", "a::c"),
            ("p::q", "d"),
            ("p::q", "p::e::F"),
            ("p::q", "p::q::g"),
            ("p::q", "h::i"),
            ("p::q", "j::k"),
            ("p::q::inner", "p::q::l"),
        ];
        let want: Vec<(String, String)> = want
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect();
        assert_eq!(to, want);
        assert_eq!(f.env_reads, [7]);
        assert_eq!(f.inline_modules, [vec!["p", "q", "inner"]]);
    }

    #[test]
    fn an_error_that_shows_its_source_is_found() {
        let text = "\
#[derive(Debug, thiserror::Error)]
enum E {
    #[error(\"{}: cannot read: {source}\", path.display())]
    Read { path: String, source: std::io::Error },
    #[error(\"{0}\")]
    Wrapped(#[from] std::fmt::Error),
    #[error(\"parse: {}\", .0)]
    Parse(#[source] std::fmt::Error),
    #[error(\"{}: cannot read\", path.display())]
    Own { path: String, source: std::io::Error },
    #[error(transparent)]
    Through(std::io::Error),
    #[error(\"{what}: {0}\")]
    NoSource(String, String),
}
";
        let f = facts(text, &[]);
        let found: Vec<_> = f
            .errors_showing_source
            .iter()
            .map(|(n, k, l)| (n.as_str(), k.as_str(), *l))
            .collect();
        assert_eq!(
            found,
            [
                ("E::Read", "source", 4),
                ("E::Wrapped", "0", 6),
                ("E::Parse", "0", 8)
            ]
        );
    }
}
