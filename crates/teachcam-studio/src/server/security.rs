//! Who may talk to the studio, and how much.
//!
//! - The server binds 127.0.0.1 unless `--listen ADDR` is given; then every `/api` request
//!   must carry the token printed with the address (`?token=` or the `x-teachcam-token`
//!   header): anyone on the network could otherwise watch the cameras.
//! - Every state-changing request (POST, and the live WebSocket's upgrade) must carry the
//!   token and an `Origin` equal to the server's own (`http://HOST:PORT` of the request's
//!   `Host`, and on loopback that host must be a loopback name): another site open in the same
//!   browser can neither start a recording nor, by DNS rebinding, read the API.
//! - `GET /api/session` ([`SESSION_PATH`]) is open: it says only whether the request's token
//!   is right, so that a page opened without it can tell the user how to open it.
//! - Request bodies are bounded ([`MAX_BODY_BYTES`]); a larger one is refused with 413.
//! - No route takes a path: the studio serves its compiled-in page, and what it computes, never
//!   a file named by a request.
//!
//! Errors are JSON `{"error": "one line"}` with the HTTP status that fits.

use std::hash::{BuildHasher, Hasher};

use axum::extract::{Request, State};
use axum::http::{HeaderMap, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::Studio;

/// The largest request body accepted, bytes: the studio's requests are a few small fields.
pub const MAX_BODY_BYTES: usize = 16 * 1024;

/// The one API route open without the token: it answers whether the page's token is this
/// studio's, so that a page opened without it (a bookmark, a second tab) can say how to open
/// it instead of failing on refused requests. It tells nothing else.
pub const SESSION_PATH: &str = "/api/session";

/// The header that carries the token.
pub const TOKEN_HEADER: &str = "x-teachcam-token";

/// An API error: its status and one line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ApiError {
    /// The HTTP status.
    pub status: StatusCode,
    /// What went wrong, on one line.
    pub message: String,
}

impl ApiError {
    /// An error with this status.
    pub fn new(status: StatusCode, message: impl Into<String>) -> Self {
        let message: String = message.into();
        Self {
            status,
            message: message.replace(['\n', '\r'], " "),
        }
    }

    /// 400: the request's fields are wrong.
    pub fn bad_request(message: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, message)
    }

    /// 422: the request is well formed but the data cannot give an answer.
    pub fn unprocessable(message: impl Into<String>) -> Self {
        Self::new(StatusCode::UNPROCESSABLE_ENTITY, message)
    }

    /// 409: the studio is not in the state the request needs.
    pub fn conflict(message: impl Into<String>) -> Self {
        Self::new(StatusCode::CONFLICT, message)
    }

    /// 403: refused.
    pub fn forbidden(message: impl Into<String>) -> Self {
        Self::new(StatusCode::FORBIDDEN, message)
    }

    /// 500: the studio failed.
    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(StatusCode::INTERNAL_SERVER_ERROR, message)
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (
            self.status,
            axum::Json(serde_json::json!({ "error": self.message })),
        )
            .into_response()
    }
}

/// A new random token: 128 bits from the standard library's per-process random keys (seeded
/// from the operating system), as 32 hexadecimal digits.
#[must_use]
pub fn new_token() -> String {
    let half = || {
        let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
        hasher.write_u128(
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos()),
        );
        hasher.finish()
    };
    format!("{:016x}{:016x}", half(), half())
}

/// The token a request carries, in its header or its query.
fn request_token<'r>(headers: &'r HeaderMap, query: Option<&'r str>) -> Option<&'r str> {
    headers
        .get(TOKEN_HEADER)
        .and_then(|v| v.to_str().ok())
        .or_else(|| {
            query?
                .split('&')
                .find_map(|pair| pair.strip_prefix("token="))
        })
}

/// Whether a request carries this studio's token.
#[must_use]
pub fn carries_token(studio: &Studio, headers: &HeaderMap, query: Option<&str>) -> bool {
    request_token(headers, query).is_some_and(|t| same(t, studio.token()))
}

/// Compares without stopping at the first difference.
fn same(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes()
            .zip(b.bytes())
            .fold(0u8, |acc, (x, y)| acc | (x ^ y))
            == 0
}

/// True for `localhost`, `127.x.x.x` and `[::1]`, with or without a port.
fn is_loopback_host(host: &str) -> bool {
    let name = if let Some(rest) = host.strip_prefix('[') {
        rest.split(']').next().unwrap_or_default()
    } else {
        host.rsplit_once(':').map_or(host, |(name, _)| name)
    };
    name.eq_ignore_ascii_case("localhost")
        || name
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// Why a request is refused, if it is.
fn refusal(
    studio: &Studio,
    method: &Method,
    path: &str,
    headers: &HeaderMap,
    query: Option<&str>,
) -> Option<String> {
    let host = headers
        .get(header::HOST)
        .and_then(|v| v.to_str().ok())
        .unwrap_or_default();
    if !studio.config().token_everywhere && !is_loopback_host(host) {
        return Some(format!(
            "host {host:?} is not this machine: the studio listens on loopback only (--listen ADDR serves others, with the token)"
        ));
    }
    if !path.starts_with("/api/") || path == SESSION_PATH {
        return None;
    }
    let token_ok = carries_token(studio, headers, query);
    let changes_state = *method != Method::GET && *method != Method::HEAD || path == "/api/live";
    if (studio.config().token_everywhere || changes_state) && !token_ok {
        return Some(format!(
            "{method} {path}: missing or wrong token (give the one printed with the address, as ?token= or the {TOKEN_HEADER} header)"
        ));
    }
    if changes_state {
        let origin = headers
            .get(header::ORIGIN)
            .and_then(|v| v.to_str().ok())
            .unwrap_or_default();
        let own = [format!("http://{host}"), format!("https://{host}")];
        if !own.iter().any(|o| o == origin) {
            return Some(format!(
                "{method} {path}: Origin {origin:?} is not this server's (http://{host})"
            ));
        }
    }
    None
}

/// The middleware that applies the module's rules to every request.
pub async fn guard(State(studio): State<Studio>, request: Request, next: Next) -> Response {
    let uri = request.uri();
    if let Some(message) = refusal(
        &studio,
        request.method(),
        uri.path(),
        request.headers(),
        uri.query(),
    ) {
        return ApiError::forbidden(message).into_response();
    }
    next.run(request).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_names_are_told_from_others() {
        for host in [
            "127.0.0.1:8080",
            "localhost:1",
            "[::1]:80",
            "127.0.0.2",
            "LOCALHOST",
        ] {
            assert!(is_loopback_host(host), "{host}");
        }
        for host in [
            "evil.example:8080",
            "192.168.1.2:80",
            "",
            "[2001:db8::1]:80",
        ] {
            assert!(!is_loopback_host(host), "{host}");
        }
    }

    #[test]
    fn tokens_are_long_and_differ() {
        let (a, b) = (new_token(), new_token());
        assert_eq!(a.len(), 32);
        assert_ne!(a, b);
        assert!(same(&a, &a) && !same(&a, &b) && !same(&a, &a[1..]));
    }
}
