//! A URL query (`?kernel=looped&spp=4`) read as the command line's flags: each `key=value`
//! is `--key=value` (a bare `key` is the switch `--key`), parsed by clap into the one
//! [`Choices`] that `render` and `view` flatten, beside the page's own arguments, and
//! checked by the one rule for flags that do not apply at [`Door::Web`]. So the web page
//! takes the render flags under their names, with their help and ranges, and refuses an
//! unknown key or a value out of range in the same one line as the command line.

use clap::{Args, FromArgMatches, Parser};

use crate::choices::{clap_error_line, Choices, Door};
use crate::{Error, Result};

/// The query as a command: the shared choices and the page's own arguments `A`.
#[derive(Parser, Debug)]
#[command(name = "the page's query", no_binary_name = true)]
struct QueryCommand<A: Args + FromArgMatches> {
    #[command(flatten)]
    choices: Choices,
    #[command(flatten)]
    page: A,
}

/// Decodes a query component: `%XX` escapes and `+` for a space.
fn decode(s: &str) -> Result<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'+' => out.push(b' '),
            b'%' => {
                let hex = s
                    .get(i + 1..i + 3)
                    .and_then(|h| u8::from_str_radix(h, 16).ok())
                    .ok_or_else(|| Error::Usage(format!("`{s}`: a bad %-escape")))?;
                out.push(hex);
                i += 2;
            }
            c => out.push(c),
        }
        i += 1;
    }
    String::from_utf8(out).map_err(|_| Error::Usage(format!("`{s}` is not UTF-8")))
}

/// The query's flags, as a command line would give them. A key given twice counts once,
/// at its first place (as `URLSearchParams.get` reads it), so a query's own `band=`
/// wins over one appended after it.
fn flags(query: &str) -> Result<Vec<String>> {
    let mut seen = std::collections::BTreeSet::new();
    let mut out = Vec::new();
    for pair in query.trim_start_matches('?').split('&') {
        if pair.is_empty() {
            continue;
        }
        let (k, v) = match pair.split_once('=') {
            Some((k, v)) => (decode(k)?, Some(decode(v)?)),
            None => (decode(pair)?, None),
        };
        if !seen.insert(k.clone()) {
            continue;
        }
        out.push(match v {
            Some(v) => format!("--{k}={v}"),
            None => format!("--{k}"),
        });
    }
    Ok(out)
}

/// Parses `query` (with or without its leading `?`) into the render choices and the
/// page's own arguments `A`, the choices checked at [`Door::Web`]. Errors are
/// [`Error::Usage`] in the command line's words (clap's first line, or the rule's).
pub fn parse_query<A: Args + FromArgMatches>(query: &str) -> Result<(Choices, A)> {
    let q = QueryCommand::<A>::try_parse_from(flags(query)?)
        .map_err(|e| Error::Usage(clap_error_line(&e)))?;
    q.choices.check(Door::Web)?;
    Ok((q.choices, q.page))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::options::{Kernel, Mask};

    /// A page argument of the page's own, as the web page declares them.
    #[derive(Args, Debug)]
    struct Page {
        /// The scene.
        #[arg(long, default_value = "whitted")]
        scene: String,
    }

    fn refusal(query: &str) -> String {
        match parse_query::<Page>(query) {
            Err(Error::Usage(m)) => m,
            other => panic!("{query}: expected a usage error, got {other:?}"),
        }
    }

    /// The page's query takes the render flags under their own names and values, and its
    /// own arguments beside them.
    #[test]
    fn the_query_is_the_render_flags() {
        let (c, p) = parse_query::<Page>(
            "?scene=cornell&kernel=unrolled%3A4&spp=3&width=64&height=48&mask=stencil\
             &max-depth=2&accel=uniform&terminator=exact",
        )
        .unwrap();
        assert_eq!(p.scene, "cornell");
        assert_eq!(c.kernel, Kernel::Unrolled(4));
        assert_eq!(c.mask, Mask::Stencil);
        assert_eq!(
            (c.spp, c.width, c.height, c.max_depth),
            (Some(3), Some(64), Some(48), Some(2))
        );
        let (c, p) = parse_query::<Page>("").unwrap();
        assert_eq!((c.kernel, p.scene.as_str()), (Kernel::Auto, "whitted"));
        // A key given twice counts at its first place.
        let (c, _) = parse_query::<Page>("spp=2&spp=5").unwrap();
        assert_eq!(c.spp, Some(2));
    }

    /// Unknown keys and values out of range are refused in the command line's own one
    /// line (the page used to ignore unknown keys, and bounded `unrolled:K` and `spp` by
    /// ranges of its own); what WebGL cannot run is refused naming the flag.
    #[test]
    fn the_query_refuses_as_the_command_line_does() {
        let cli = |flags: &[&str]| match crate::choices::RenderArgs::try_parse_from_args(flags)
            .and_then(|a| a.to_options(&crate::scene::builtin_scene()))
        {
            Err(Error::Usage(m)) => m,
            other => panic!("{flags:?}: expected a usage error, got {other:?}"),
        };
        for (query, flags) in [
            ("spp=0", &["--spp", "0"][..]),
            ("spp=2000", &["--spp", "2000"][..]),
            ("width=-5", &["--width", "-5"][..]),
            ("max-depth=99", &["--max-depth", "99"][..]),
            ("kernel=unrolled:65", &["--kernel", "unrolled:65"][..]),
            ("kernel=bogus", &["--kernel", "bogus"][..]),
            ("mask=sometimes", &["--mask", "sometimes"][..]),
        ] {
            let (page, cmd) = (refusal(query), cli(flags));
            assert_eq!(page, cmd, "{query}");
            assert!(!page.contains('\n'), "{page}");
        }
        let m = refusal("colour=red");
        assert!(m.contains("--colour"), "{m}");
        for (query, flag) in [
            ("kernel=compute", "--kernel compute"),
            ("scene-fetch=texel-fetch", "--scene-fetch texel-fetch"),
            ("backend=cpu", "--backend cpu"),
            ("precision=f64", "--precision f64"),
            ("accel=bvh", "--accel bvh"),
            ("gpu=0", "--gpu 0"),
        ] {
            let m = refusal(query);
            assert!(m.starts_with(flag), "{query}: {m}");
            assert!(!m.contains('\n'), "{m}");
        }
    }
}
