//! A set's URL: which store, which prefix inside it, the normalised spelling that names
//! the set in messages and keys its cache folder, and the object_store client for it.

use crate::{FetchOptions, RemoteError};
use object_store::aws::{AmazonS3Builder, AmazonS3ConfigKey};
use object_store::http::HttpBuilder;
use object_store::path::Path as ObjectPath;
use object_store::{BackoffConfig, ClientConfigKey, ObjectStore, RetryConfig};
use std::sync::Arc;
use std::time::Duration;

/// Whether `source` is a URL this crate fetches (`s3://`, `http://`, `https://`) rather
/// than a folder.
pub fn is_remote(source: &str) -> bool {
    scheme(source).is_some()
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scheme {
    S3,
    Http,
}

fn scheme(source: &str) -> Option<Scheme> {
    let (s, rest) = source.split_once("://")?;
    if rest.is_empty() {
        return None;
    }
    match s.to_ascii_lowercase().as_str() {
        "s3" => Some(Scheme::S3),
        "http" | "https" => Some(Scheme::Http),
        _ => None,
    }
}

/// A parsed set URL.
#[derive(Clone, Debug)]
pub(crate) struct Location {
    scheme: Scheme,
    /// `s3://bucket/prefix` or `https://host/path`, no trailing slash, no query: the
    /// set's name in every message.
    pub url: String,
    /// S3: the bucket; HTTP: unused.
    bucket: String,
    /// The folder inside the store (S3: the key prefix; HTTP: empty, the URL is the base).
    prefix: String,
}

impl Location {
    pub fn parse(source: &str) -> Result<Location, RemoteError> {
        let bad = |reason: &str| RemoteError::BadUrl {
            url: source.to_string(),
            reason: reason.to_string(),
        };
        let scheme = scheme(source)
            .ok_or_else(|| bad("expected s3://bucket/prefix or http(s)://host/path"))?;
        // Checked on the text: the URL parser would resolve them silently.
        let after_scheme = source.split_once("://").map_or("", |(_, r)| r);
        if after_scheme.split('/').any(|s| s == "." || s == "..") {
            return Err(bad("'.' and '..' are not allowed in the path"));
        }
        let parsed = url::Url::parse(source).map_err(|e| bad(&e.to_string()))?;
        if parsed.query().is_some() || parsed.fragment().is_some() {
            return Err(bad("a query or fragment is not part of a set's address"));
        }
        if !parsed.username().is_empty() || parsed.password().is_some() {
            return Err(bad(
                "credentials do not belong in the URL (S3: the AWS_* environment variables)",
            ));
        }
        let host = parsed
            .host_str()
            .filter(|h| !h.is_empty())
            .ok_or_else(|| bad("no host (S3: no bucket)"))?;
        // The set's folder: `.../manifest.json` names the same set as its folder.
        let mut segments: Vec<String> = parsed
            .path_segments()
            .map(|s| s.filter(|p| !p.is_empty()).map(str::to_string).collect())
            .unwrap_or_default();
        if segments.last().map(String::as_str) == Some(shards::MANIFEST_FILE) {
            segments.pop();
        }
        let path = segments.join("/");
        Ok(match scheme {
            Scheme::S3 => {
                if parsed.port().is_some() {
                    return Err(bad(
                        "s3:// takes a bucket, not host:port (the server goes in AWS_ENDPOINT_URL)",
                    ));
                }
                let url = if path.is_empty() {
                    format!("s3://{host}")
                } else {
                    format!("s3://{host}/{path}")
                };
                Location {
                    scheme,
                    url,
                    bucket: host.to_string(),
                    prefix: path,
                }
            }
            Scheme::Http => {
                let mut base = parsed.clone();
                base.set_path(&path);
                let url = base.as_str().trim_end_matches('/').to_string();
                Location {
                    scheme,
                    url,
                    bucket: String::new(),
                    prefix: String::new(),
                }
            }
        })
    }

    /// The URL of `file` in the set, for messages.
    pub fn file_url(&self, file: &str) -> String {
        format!("{}/{file}", self.url)
    }

    /// The path of `file` in the store.
    pub fn object_path(&self, file: &str) -> Result<ObjectPath, RemoteError> {
        let key = if self.prefix.is_empty() {
            file.to_string()
        } else {
            format!("{}/{file}", self.prefix)
        };
        ObjectPath::parse(&key).map_err(|e| RemoteError::BadUrl {
            url: self.file_url(file),
            reason: e.to_string(),
        })
    }

    /// The client, and what besides the URL tells two sets apart (an S3 URL's endpoint:
    /// the same bucket name on two servers is two sets).
    pub fn store(&self, o: &FetchOptions) -> Result<(Arc<dyn ObjectStore>, String), RemoteError> {
        let retry = RetryConfig {
            backoff: BackoffConfig {
                init_backoff: Duration::from_millis(100),
                max_backoff: Duration::from_secs(5)
                    .min(o.retry_timeout.max(Duration::from_millis(100))),
                base: 2.0,
            },
            max_retries: o.retries,
            retry_timeout: o.retry_timeout,
        };
        let timeout = format!("{} ms", o.request_timeout.as_millis().max(1));
        let failed = |e: object_store::Error| RemoteError::BadUrl {
            url: self.url.clone(),
            reason: e.to_string(),
        };
        match self.scheme {
            Scheme::S3 => {
                // The standard AWS_* variables (credentials, region, AWS_ENDPOINT_URL,
                // AWS_ALLOW_HTTP ...), then the caller's own settings over them.
                let mut b = AmazonS3Builder::from_env();
                for (k, v) in &o.s3_config {
                    let key: AmazonS3ConfigKey = k.parse().map_err(|_| RemoteError::BadUrl {
                        url: self.url.clone(),
                        reason: format!("{k:?} is not an S3 setting"),
                    })?;
                    b = b.with_config(key, v);
                }
                let endpoint = b
                    .get_config_value(&AmazonS3ConfigKey::Endpoint)
                    .unwrap_or_default();
                let store = b
                    .with_bucket_name(&self.bucket)
                    .with_retry(retry)
                    .with_config(
                        AmazonS3ConfigKey::Client(ClientConfigKey::Timeout),
                        &timeout,
                    )
                    .build()
                    .map_err(failed)?;
                Ok((Arc::new(store), endpoint))
            }
            Scheme::Http => {
                let store = HttpBuilder::new()
                    .with_url(&self.url)
                    .with_retry(retry)
                    .with_config(ClientConfigKey::AllowHttp, "true")
                    .with_config(ClientConfigKey::Timeout, &timeout)
                    .build()
                    .map_err(failed)?;
                Ok((Arc::new(store), String::new()))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_are_normalised() {
        assert!(is_remote("s3://b/p") && is_remote("HTTPS://h/p") && is_remote("http://h"));
        for local in ["work/shard", "/abs/shard", "file:///x", "s3://", "C:\\x"] {
            assert!(!is_remote(local), "{local}");
        }
        let l = Location::parse("s3://bucket/a/b/").unwrap();
        assert_eq!(
            (l.url.as_str(), l.prefix.as_str()),
            ("s3://bucket/a/b", "a/b")
        );
        assert_eq!(l.object_path("x.mcap").unwrap().as_ref(), "a/b/x.mcap");
        let l = Location::parse("s3://bucket/a/manifest.json").unwrap();
        assert_eq!(l.url, "s3://bucket/a");
        let l = Location::parse("s3://bucket").unwrap();
        assert_eq!(l.object_path("m.json").unwrap().as_ref(), "m.json");
        let l = Location::parse("HTTP://Host.Example:8080//sets/one//").unwrap();
        assert_eq!(l.url, "http://host.example:8080/sets/one");
        assert_eq!(
            l.file_url("manifest.json"),
            "http://host.example:8080/sets/one/manifest.json"
        );
        for bad in [
            "s3://bucket:9000/p",
            "https://h/p?x=1",
            "https://user:pw@h/p",
            "s3://b/../p",
        ] {
            let e = Location::parse(bad).unwrap_err().to_string();
            assert!(e.starts_with(bad), "{e}");
        }
    }
}
