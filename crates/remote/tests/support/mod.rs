//! Real servers for the object-storage tests, each started on 127.0.0.1 at a free port in
//! a temporary folder and stopped by its pid when dropped: s3s-fs (the s3s project's
//! file-system S3 server, installed by scripts/setup-s3.sh) and Python's http.server.
//! Where one cannot be started the caller skips, printing the reason. Also used by
//! tests/remote_shards.rs (included by path).

#![allow(dead_code)]

use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Credentials the S3 server is started with (any pair works; SigV4 is checked).
pub const ACCESS_KEY: &str = "pl2map-test";
pub const SECRET_KEY: &str = "pl2map-test-secret";
pub const REGION: &str = "us-east-1";

/// A port nobody listened on a moment ago.
pub fn free_port() -> u16 {
    let l = TcpListener::bind("127.0.0.1:0").expect("binding 127.0.0.1:0");
    l.local_addr().expect("local address").port()
}

/// A started server process, killed (by pid) and reaped when dropped.
pub struct Server {
    child: Child,
    pub port: u16,
    /// Where the server keeps its data: the S3 root (a bucket is a subfolder) or the
    /// HTTP document root.
    pub root: PathBuf,
    /// The server's log (its stderr).
    pub log: PathBuf,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Server {
    fn start(mut cmd: Command, port: u16, root: PathBuf, log: PathBuf) -> Result<Server, String> {
        let log_file =
            std::fs::File::create(&log).map_err(|e| format!("{}: {e}", log.display()))?;
        let child = cmd
            .stdin(Stdio::null())
            .stdout(log_file.try_clone().map_err(|e| e.to_string())?)
            .stderr(log_file)
            .spawn()
            .map_err(|e| format!("cannot start {cmd:?}: {e}"))?;
        let mut server = Server {
            child,
            port,
            root,
            log,
        };
        let addr = SocketAddr::from(([127, 0, 0, 1], port));
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(20) {
            if TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_ok() {
                return Ok(server);
            }
            if let Ok(Some(status)) = server.child.try_wait() {
                return Err(format!(
                    "{cmd:?} exited ({status}): {}",
                    std::fs::read_to_string(&server.log).unwrap_or_default()
                ));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        Err(format!("{cmd:?} did not listen on {addr} within 20 s"))
    }

    pub fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

/// The s3s-fs binary: `PL2MAP_S3S_FS`, else scripts/setup-s3.sh's install, else PATH.
pub fn s3s_fs_binary() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("PL2MAP_S3S_FS") {
        return Some(PathBuf::from(p));
    }
    let home = std::env::var_os("HOME").map(PathBuf::from)?;
    let installed = home.join(".cache/pl2map-rs/tools/bin/s3s-fs");
    if installed.is_file() {
        return Some(installed);
    }
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join("s3s-fs"))
            .find(|p| p.is_file())
    })
}

/// s3s-fs serving `dir/s3` with [`ACCESS_KEY`] / [`SECRET_KEY`] and the bucket `bucket`;
/// Err says why it could not be started (the caller skips).
pub fn start_s3(dir: &Path, bucket: &str) -> Result<Server, String> {
    let bin = s3s_fs_binary().ok_or(
        "s3s-fs is not installed (scripts/setup-s3.sh installs it; PL2MAP_S3S_FS names a binary)",
    )?;
    let root = dir.join("s3");
    std::fs::create_dir_all(root.join(bucket)).map_err(|e| e.to_string())?;
    let port = free_port();
    let mut cmd = Command::new(&bin);
    cmd.args(["--host", "127.0.0.1", "--port", &port.to_string()])
        .args(["--access-key", ACCESS_KEY, "--secret-key", SECRET_KEY])
        .arg(&root)
        .env("RUST_LOG", "s3s=info");
    Server::start(cmd, port, root, dir.join("s3.log"))
}

/// The Python interpreter for http.server: `PL2MAP_PYTHON`, else `python3`.
pub fn python() -> PathBuf {
    std::env::var_os("PL2MAP_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("python3"))
}

/// `python3 -m http.server` serving `dir/www` (a plain folder: the URL path is the file
/// path); its log lists every request.
pub fn start_http(dir: &Path) -> Result<Server, String> {
    let root = dir.join("www");
    std::fs::create_dir_all(&root).map_err(|e| e.to_string())?;
    let port = free_port();
    let mut cmd = Command::new(python());
    cmd.args(["-u", "-m", "http.server", "--bind", "127.0.0.1"])
        .arg(port.to_string())
        .arg("--directory")
        .arg(&root);
    Server::start(cmd, port, root, dir.join("http.log"))
}

/// S3 settings (object_store's config keys) for a server started by [`start_s3`].
pub fn s3_config(server: &Server) -> Vec<(String, String)> {
    s3_env(server)
        .into_iter()
        .map(|(k, v)| (k.to_ascii_lowercase(), v))
        .collect()
}

/// The standard AWS environment variables for a server started by [`start_s3`].
pub fn s3_env(server: &Server) -> Vec<(String, String)> {
    [
        ("AWS_ACCESS_KEY_ID", ACCESS_KEY.to_string()),
        ("AWS_SECRET_ACCESS_KEY", SECRET_KEY.to_string()),
        ("AWS_REGION", REGION.to_string()),
        (
            "AWS_ENDPOINT_URL",
            format!("http://127.0.0.1:{}", server.port),
        ),
        ("AWS_ALLOW_HTTP", "true".to_string()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

/// Publishes the set in `src` to `s3://bucket/prefix` with real PUTs (remote::publish).
pub fn upload_s3(server: &Server, bucket: &str, prefix: &str, src: &Path) {
    let url = format!("s3://{bucket}/{prefix}");
    let o = remote::FetchOptions {
        s3_config: s3_config(server),
        ..remote::FetchOptions::default()
    };
    remote::publish(src, &url, &o).unwrap_or_else(|e| panic!("publishing to {url}: {e}"));
}

/// Copies the files of `src` into the HTTP server's folder `path`.
pub fn publish_http(server: &Server, path: &str, src: &Path) {
    let dst = server.root.join(path);
    std::fs::create_dir_all(&dst).unwrap();
    for name in files_of(src) {
        std::fs::copy(src.join(&name), dst.join(&name)).unwrap();
    }
}

/// The regular files directly in `dir`, sorted.
pub fn files_of(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Requests of `path` (e.g. "/set/train-00000.mcap") in an http.server log.
pub fn http_gets(server: &Server, path: &str) -> usize {
    let needle = format!("\"GET {path} HTTP/");
    server.log_text().matches(&needle).count()
}
