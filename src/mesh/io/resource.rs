//! External glTF resources: a buffer `uri` turned into a path that cannot
//! leave the model's folder, and the resolver that supplies its bytes.
//!
//! A `.gltf` is untrusted input, and its `uri` strings are chosen by whoever
//! wrote it. The loader therefore never hands a raw URI to a resolver: it
//! first reduces it to a [`ResourcePath`], plain names below the model's
//! folder, and refuses absolute paths, `..`, schemes and anything that
//! decodes to them. A resolver only has to map those names to bytes.

use std::fmt;

/// A relative path below the model's folder, from a glTF `uri`: its
/// components are plain names (no `..`, no `.`, no separators, no NUL).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ResourcePath {
    components: Vec<String>,
}

impl ResourcePath {
    /// Parses a glTF `uri` (a relative URI reference, percent-encoded).
    /// Fails, saying why, for anything that could name a file outside the
    /// model's folder or that is not a file name at all.
    pub fn parse(uri: &str) -> Result<ResourcePath, String> {
        if uri.is_empty() {
            return Err("the URI is empty".into());
        }
        // A scheme ("file:", "http:", a drive letter "C:") comes before the
        // first '/': a relative reference has none.
        let head = uri.split('/').next().unwrap_or_default();
        if head.contains(':') {
            return Err(
                "the URI has a scheme or drive letter; only paths relative to the model's folder are read".into(),
            );
        }
        if uri.contains(['?', '#']) {
            return Err("the URI has a query or fragment".into());
        }
        let decoded = percent_decode(uri)?;
        if decoded.contains('\0') {
            return Err("the URI contains a NUL character".into());
        }
        if decoded.contains('\\') {
            return Err(
                "the URI contains a backslash, which some systems read as a separator".into(),
            );
        }
        if decoded.starts_with('/') {
            return Err(
                "the URI is an absolute path; only paths relative to the model's folder are read"
                    .into(),
            );
        }
        if decoded.ends_with('/') || decoded.ends_with("/.") {
            return Err("the URI names a folder, not a file".into());
        }
        let mut components = Vec::new();
        for part in decoded.split('/') {
            match part {
                "" | "." => {}
                ".." => {
                    return Err("the URI climbs out of the model's folder with '..'".into());
                }
                name => components.push(name.to_string()),
            }
        }
        if components.is_empty() {
            return Err("the URI names a folder, not a file".into());
        }
        Ok(ResourcePath { components })
    }

    /// The plain names, outermost folder first.
    pub fn components(&self) -> impl Iterator<Item = &str> {
        self.components.iter().map(String::as_str)
    }
}

impl fmt::Display for ResourcePath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.components.join("/"))
    }
}

/// Decodes `%XX` escapes; the result must be UTF-8.
fn percent_decode(uri: &str) -> Result<String, String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or("the URI has a '%' that is not followed by two hex digits")?;
            out.push(hex);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| "the URI does not decode to UTF-8".to_string())
}

/// Why a resolver could not supply a resource.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ResourceError {
    /// There is no such resource.
    Missing,
    /// It exists but may not or cannot be read (a link out of the folder,
    /// not a regular file, an I/O error), in words.
    Refused(String),
}

/// Supplies the external files a `.gltf` refers to.
pub trait ResourceResolver {
    /// At most `max_len` bytes of the resource at `path` (the buffer's
    /// declared `byteLength`: more is never used).
    fn resolve(&self, path: &ResourcePath, max_len: usize) -> Result<Vec<u8>, ResourceError>;
}

/// A resolver that has nothing: every external reference is an error.
pub struct NoResources;

impl ResourceResolver for NoResources {
    fn resolve(&self, _: &ResourcePath, _: usize) -> Result<Vec<u8>, ResourceError> {
        Err(ResourceError::Missing)
    }
}

/// Resources held in memory (dropped files, tests): the closure gets the
/// path as `a/b.bin` and returns its bytes, if it has them.
impl<F: Fn(&str) -> Option<Vec<u8>>> ResourceResolver for F {
    fn resolve(&self, path: &ResourcePath, max_len: usize) -> Result<Vec<u8>, ResourceError> {
        let mut bytes = self(&path.to_string()).ok_or(ResourceError::Missing)?;
        bytes.truncate(max_len);
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(uri: &str) -> Vec<String> {
        ResourcePath::parse(uri)
            .unwrap_or_else(|e| panic!("{uri}: {e}"))
            .components()
            .map(str::to_string)
            .collect()
    }

    #[test]
    fn plain_relative_names_are_kept() {
        assert_eq!(names("tri.bin"), ["tri.bin"]);
        assert_eq!(names("./data//parts/a.bin"), ["data", "parts", "a.bin"]);
        assert_eq!(names("my%20file.bin"), ["my file.bin"]);
        assert_eq!(names("caf%C3%A9.bin"), ["café.bin"]);
    }

    #[test]
    fn every_way_out_of_the_folder_is_refused() {
        for uri in [
            "/etc/passwd",
            "../secret.bin",
            "a/../../secret.bin",
            "a/..",
            "%2e%2e/secret.bin",
            "%2E%2E%2Fsecret.bin",
            "%2fetc/passwd",
            "..\\secret.bin",
            "a%5c..%5csecret.bin",
            "file:///etc/passwd",
            "C:/Windows/win.ini",
            "c:secret.bin",
            "http://example.invalid/a.bin",
            "a.bin%00.png",
            "a.bin?x=1",
            "a.bin#frag",
            "%zz.bin",
            "%e9.bin",
            "",
            ".",
            "a/./",
        ] {
            assert!(ResourcePath::parse(uri).is_err(), "{uri} was accepted");
        }
    }

    #[test]
    fn a_closure_resolver_is_cut_to_the_declared_length() {
        let resolver = |name: &str| (name == "a/b.bin").then(|| vec![7u8; 100]);
        let path = ResourcePath::parse("a/b.bin").unwrap();
        assert_eq!(resolver.resolve(&path, 10).unwrap().len(), 10);
        let other = ResourcePath::parse("c.bin").unwrap();
        assert_eq!(resolver.resolve(&other, 10), Err(ResourceError::Missing));
    }
}
