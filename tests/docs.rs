//! The docs as a user meets them, checked in seconds:
//!
//! - every command shown in a code block of the project's Markdown (README, CHANGELOG, docs/,
//!   the clients' and tools' READMEs) that runs one of the project's binaries parses with that
//!   binary's clap definition, in-process (`Cli::try_parse_from`);
//! - every relative link resolves: the file exists and a `#heading` names a heading in it (the
//!   GitHub anchor of its text);
//! - every scene file the docs name (`scenes/NAME.toml`) loads, and so does every whole scene
//!   quoted in a TOML block (as a file in `scenes/`); a fragment of one parses;
//! - `docs/reference/cli/` is what clap-markdown writes for the clap definitions now. After
//!   changing a command line, rewrite the pages with
//!   `SPLATPHYS_BLESS=1 cargo test --release -p splatphys-tests --test docs`.

use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser};
use pulldown_cmark::{CodeBlockKind, Event, Tag, TagEnd};

/// The project's binaries, as a command in the docs names them.
const BINARIES: [&str; 8] = [
    "splatphys",
    "splatphys-bench",
    "splatphys-record",
    "splatphys-render",
    "splatphys-control",
    "splatphys-web",
    "splatphys-probe",
    "splatphys-zenoh",
];

fn root() -> PathBuf {
    splatphys_tests::workspace().to_path_buf()
}

/// The project's Markdown files (not build outputs, not installed packages).
fn markdown_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let path = e.path();
            let name = e.file_name();
            let name = name.to_string_lossy();
            if path.is_dir() {
                if !name.starts_with('.') && !matches!(&*name, "target" | "node_modules" | "out") {
                    walk(&path, out);
                }
            } else if name.ends_with(".md") {
                out.push(path);
            }
        }
    }
    let mut out = Vec::new();
    walk(&root(), &mut out);
    out.sort();
    out
}

/// `path` relative to the root, for messages.
fn rel(path: &Path) -> String {
    path.strip_prefix(root())
        .unwrap_or(path)
        .display()
        .to_string()
}

/// The 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

/// `line` without a shell comment (`#` at the start or after whitespace, outside quotes).
fn strip_comment(line: &str) -> &str {
    let (mut quote, mut prev_space) = (None, true);
    for (i, c) in line.char_indices() {
        match (quote, c) {
            (None, '\'' | '"') => quote = Some(c),
            (Some(q), _) if c == q => quote = None,
            (None, '#') if prev_space => return &line[..i],
            _ => {}
        }
        prev_space = c.is_whitespace();
    }
    line
}

/// The project binary a command word runs (`splatphys`, `target/release/splatphys`, ...).
fn binary(word: &str) -> Option<&'static str> {
    let word = word.strip_prefix("./").unwrap_or(word);
    let name = word
        .strip_prefix("target/release/")
        .or_else(|| word.strip_prefix("target/debug/"))
        .unwrap_or(word);
    BINARIES.iter().copied().find(|b| *b == name)
}

/// The project commands in a code block: each `(line, argv)` whose first word (after any
/// `NAME=value`) is a project binary; `&&`, `||`, `|`, `;` and `&` separate commands, a trailing
/// `\` continues a line.
fn commands(block: &str) -> Vec<(usize, Vec<String>)> {
    let mut out = Vec::new();
    let mut joined = String::new();
    let mut first_line = 0;
    for (i, line) in block.lines().enumerate() {
        if joined.is_empty() {
            first_line = i;
        }
        let line = line.trim();
        let line = line.strip_prefix("$ ").unwrap_or(line);
        if let Some(head) = line.strip_suffix('\\') {
            joined.push_str(head);
            joined.push(' ');
            continue;
        }
        joined.push_str(strip_comment(line));
        let text = std::mem::take(&mut joined);
        let Ok(words) = shell_words::split(&text) else {
            // Not shell (prose or a TOML/JSON/Python fragment): a command never fails to split.
            if BINARIES.iter().any(|b| text.trim_start().starts_with(b)) {
                out.push((first_line, vec![format!("<unbalanced quotes> {text}")]));
            }
            continue;
        };
        for segment in words.split(|w| matches!(w.as_str(), "&&" | "||" | "|" | ";" | "&")) {
            let start = segment
                .iter()
                .position(|w| !w.contains('=') || w.starts_with('-'))
                .unwrap_or(segment.len());
            let segment = &segment[start..];
            if let Some(bin) = segment.first().and_then(|w| binary(w)) {
                let mut argv = vec![bin.to_owned()];
                argv.extend(segment[1..].iter().cloned());
                out.push((first_line, argv));
            }
        }
    }
    out
}

/// Parses `argv` (`argv[0]` a project binary) with that binary's clap definition.
fn parse(argv: &[String]) -> Result<(), String> {
    fn check<C: Parser>(argv: &[String]) -> Result<Option<C>, String> {
        match C::try_parse_from(argv) {
            Ok(c) => Ok(Some(c)),
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::DisplayHelp
                        | ErrorKind::DisplayVersion
                        | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
                ) =>
            {
                Ok(None)
            }
            Err(e) => Err(e.render().to_string()),
        }
    }
    match argv[0].as_str() {
        "splatphys" => {
            if let Some(cli) = check::<splatphys::cli::Cli>(argv)?
                && let splatphys::cli::Command::Bench { args } = cli.command
            {
                // `splatphys bench ARGS` runs `splatphys-bench ARGS`.
                let mut bench = vec!["splatphys-bench".to_owned()];
                bench.extend(args.iter().map(|a| a.to_string_lossy().into_owned()));
                return parse(&bench);
            }
            Ok(())
        }
        "splatphys-bench" => check::<splatphys_bench::cli::Cli>(argv).map(drop),
        "splatphys-record" => check::<splatphys_record::cli::Cli>(argv).map(drop),
        "splatphys-render" => check::<splatphys_render::cli::Cli>(argv).map(drop),
        "splatphys-control" => check::<splatphys_control::cli::Cli>(argv).map(drop),
        "splatphys-web" => check::<splatphys_web::cli::Cli>(argv).map(drop),
        "splatphys-probe" => check::<splatphys_probe::Cli>(argv).map(drop),
        "splatphys-zenoh" => check::<splatphys_zenoh::cli::Cli>(argv).map(drop),
        other => Err(format!("{other} is not a project binary")),
    }
}

/// The code blocks of a Markdown text: (first line of the block's content, text).
fn code_blocks(text: &str) -> Vec<(usize, String)> {
    blocks(text).into_iter().map(|(l, _, t)| (l, t)).collect()
}

/// The code blocks of a Markdown text: (first line of the content, fence language, text).
fn blocks(text: &str) -> Vec<(usize, String, String)> {
    let mut out = Vec::new();
    let mut current: Option<(usize, String, String)> = None;
    for (event, range) in pulldown_cmark::Parser::new(text).into_offset_iter() {
        match event {
            Event::Start(Tag::CodeBlock(kind)) => {
                // A fenced block's content starts on the line after its fence.
                let (skip, lang) = match kind {
                    CodeBlockKind::Fenced(info) => (1, info.to_string()),
                    CodeBlockKind::Indented => (0, String::new()),
                };
                current = Some((line_of(text, range.start) + skip, lang, String::new()));
            }
            Event::Text(t) => {
                if let Some((_, _, s)) = current.as_mut() {
                    s.push_str(&t);
                }
            }
            Event::End(TagEnd::CodeBlock) => out.extend(current.take()),
            _ => {}
        }
    }
    out
}

#[test]
fn every_command_shown_in_the_docs_parses() {
    let mut failures = Vec::new();
    let mut checked = 0;
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).expect("read");
        for (line, block) in code_blocks(&text) {
            for (offset, argv) in commands(&block) {
                checked += 1;
                if let Err(e) = parse(&argv) {
                    let first = e.lines().next().unwrap_or_default().to_owned();
                    failures.push(format!(
                        "{}:{}: `{}`: {first}",
                        rel(&file),
                        line + offset,
                        argv.join(" ")
                    ));
                }
            }
        }
    }
    println!("{checked} commands checked");
    assert!(checked > 50, "only {checked} commands found in the docs");
    assert!(
        failures.is_empty(),
        "{} commands in the docs do not parse:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// The GitHub anchors of a Markdown text's headings: lower case, punctuation other than `-` and
/// `_` dropped, spaces to `-`, a repeated anchor numbered `-1`, `-2`, ...
fn anchors(text: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut heading: Option<String> = None;
    for event in pulldown_cmark::Parser::new(text) {
        match event {
            Event::Start(Tag::Heading { .. }) => heading = Some(String::new()),
            Event::Text(t) | Event::Code(t) => {
                if let Some(h) = heading.as_mut() {
                    h.push_str(&t);
                }
            }
            Event::End(TagEnd::Heading(_)) => {
                let h = heading.take().unwrap_or_default();
                let slug: String = h
                    .to_lowercase()
                    .chars()
                    .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
                    .map(|c| if c == ' ' { '-' } else { c })
                    .collect();
                let n = seen.entry(slug.clone()).or_default();
                out.insert(if *n == 0 {
                    slug.clone()
                } else {
                    format!("{slug}-{n}")
                });
                *n += 1;
            }
            _ => {}
        }
    }
    out
}

#[test]
fn every_relative_link_resolves() {
    let mut failures = Vec::new();
    let mut checked = 0;
    let mut cache: HashMap<PathBuf, BTreeSet<String>> = HashMap::new();
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).expect("read");
        let dir = file.parent().expect("dir");
        for (event, range) in pulldown_cmark::Parser::new(&text).into_offset_iter() {
            let dest = match event {
                Event::Start(Tag::Link { dest_url, .. } | Tag::Image { dest_url, .. }) => dest_url,
                _ => continue,
            };
            if dest.contains("://") || dest.starts_with("mailto:") {
                continue;
            }
            checked += 1;
            let (path, anchor) = dest.split_once('#').unwrap_or((&dest, ""));
            let target = if path.is_empty() {
                file.clone()
            } else {
                dir.join(path)
            };
            let at = format!("{}:{}: `{dest}`", rel(&file), line_of(&text, range.start));
            if !target.exists() {
                failures.push(format!("{at}: no such file"));
                continue;
            }
            if anchor.is_empty() || target.extension().is_none_or(|e| e != "md") {
                continue;
            }
            let names = cache.entry(target.clone()).or_insert_with(|| {
                anchors(&std::fs::read_to_string(&target).expect("read target"))
            });
            if !names.contains(anchor) {
                failures.push(format!("{at}: no heading #{anchor} in {}", rel(&target)));
            }
        }
    }
    println!("{checked} relative links checked");
    assert!(checked > 50, "only {checked} relative links found");
    assert!(
        failures.is_empty(),
        "{} links do not resolve:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn every_scene_file_the_docs_name_loads() {
    let mut named = BTreeSet::new();
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).expect("read");
        for (i, _) in text.match_indices("scenes/") {
            let name: String = text[i + "scenes/".len()..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
                .collect();
            if let Some(stem) = name.strip_suffix(".toml") {
                named.insert((format!("scenes/{stem}.toml"), rel(&file)));
            }
        }
    }
    assert!(named.len() >= 5, "only {} scene files named", named.len());
    let mut failures = Vec::new();
    let mut loaded = BTreeSet::new();
    for (scene, file) in &named {
        let path = root().join(scene);
        if !path.exists() {
            failures.push(format!("{file}: {scene}: no such file"));
        } else if loaded.insert(scene.clone())
            && let Err(e) = splatphys_core::scene::load_scene(&path)
        {
            failures.push(format!("{file}: {scene}: {e}"));
        }
    }
    println!("{} scene files loaded", loaded.len());
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_scene_quoted_in_the_docs_loads() {
    // A TOML block with an `[[object]]` whose sources are all in it is a whole scene: it loads as
    // a file in `scenes/` would (the docs say to save it there). Any other TOML block that uses a
    // scene table is a fragment of one: it parses.
    let mut failures = Vec::new();
    let (mut whole, mut fragments) = (0, 0);
    let scenes = root().join("scenes");
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).expect("read");
        for (line, lang, block) in blocks(&text) {
            if lang.trim() != "toml" {
                continue;
            }
            let at = format!("{}:{line}", rel(&file));
            let scene_tables = ["[simulation]", "[[source]]", "[[object]]", "[[collider]]"];
            let needs_sources = block.contains("source = ") && !block.contains("[[source]]");
            if block.contains("[[object]]") && !needs_sources {
                whole += 1;
                if let Err(e) = splatphys_core::scene::load_scene_str(&block, &scenes) {
                    failures.push(format!("{at}: {e}"));
                }
            } else if scene_tables.iter().any(|t| block.contains(t)) {
                fragments += 1;
                let path = Path::new("<fragment>");
                if let Err(e) = splatphys_core::scene::parse_scene_toml(path, &block) {
                    failures.push(format!("{at}: {e}"));
                }
            }
        }
    }
    println!("{whole} whole scenes loaded, {fragments} fragments parsed");
    assert!(whole >= 2, "only {whole} whole scenes quoted in the docs");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Each binary's name and clap definition.
fn clis() -> Vec<(&'static str, clap::Command)> {
    vec![
        ("splatphys", splatphys::cli::Cli::command()),
        ("splatphys-bench", splatphys_bench::cli::Cli::command()),
        ("splatphys-record", splatphys_record::cli::Cli::command()),
        ("splatphys-render", splatphys_render::cli::Cli::command()),
        ("splatphys-control", splatphys_control::cli::Cli::command()),
        ("splatphys-web", splatphys_web::cli::Cli::command()),
        ("splatphys-probe", splatphys_probe::Cli::command()),
        ("splatphys-zenoh", splatphys_zenoh::cli::Cli::command()),
    ]
}

#[test]
fn the_cli_reference_matches_the_clap_definitions() {
    let dir = root().join("docs/reference/cli");
    let bless = std::env::var_os("SPLATPHYS_BLESS").is_some();
    let mut stale = Vec::new();
    for (name, command) in clis() {
        let options = clap_markdown::MarkdownOptions::new()
            .title(format!("`{name}` command line"))
            .show_footer(false);
        let page = format!(
            "<!-- Generated from the clap definitions by `SPLATPHYS_BLESS=1 cargo test --release -p splatphys-tests --test docs`; do not edit. -->\n\n{}",
            clap_markdown::help_markdown_command_custom(&command, &options)
        );
        let path = dir.join(format!("{name}.md"));
        if bless {
            std::fs::create_dir_all(&dir).expect("create docs/reference/cli");
            std::fs::write(&path, &page).expect("write");
        } else if std::fs::read_to_string(&path).ok().as_deref() != Some(page.as_str()) {
            stale.push(rel(&path));
        }
    }
    assert!(
        stale.is_empty(),
        "out of date with the clap definitions: {}; rewrite with `SPLATPHYS_BLESS=1 cargo test --release -p splatphys-tests --test docs`",
        stale.join(", ")
    );
}

#[test]
fn shell_comments_and_separators_are_understood() {
    let block = "target/release/splatphys run --out out/a   # the main job\n\
                 FOO=1 splatphys-probe splatphys/x --frames 3 && echo done\n\
                 splatphys serve scenes/a.toml &\n\
                 splatphys-control --prefix p \\\n  pause\n\
                 python3 x.py";
    let got: Vec<(usize, String)> = commands(block)
        .into_iter()
        .map(|(l, a)| (l, a.join(" ")))
        .collect();
    assert_eq!(
        got,
        [
            (0, "splatphys run --out out/a".to_owned()),
            (1, "splatphys-probe splatphys/x --frames 3".to_owned()),
            (2, "splatphys serve scenes/a.toml".to_owned()),
            (3, "splatphys-control --prefix p pause".to_owned()),
        ]
    );
    assert!(parse(&["splatphys".into(), "run".into(), "--no-such-flag".into()]).is_err());
    assert!(parse(&["splatphys".into(), "bench".into(), "no-such-bench".into()]).is_err());
    let slugs = anchors("# A `b` c (d)\n## A b c d\n");
    assert!(
        slugs.contains("a-b-c-d") && slugs.contains("a-b-c-d-1"),
        "{slugs:?}"
    );
}
