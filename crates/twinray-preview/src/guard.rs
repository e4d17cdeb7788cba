//! Who may talk to the server: only its own page.
//!
//! Every request must name the server by an address it listens on: its
//! `Host` is `127.0.0.1`, `localhost`, `[::1]` or the `--bind` address,
//! with the port it listens on. A page of another site whose name was made
//! to resolve to this machine (DNS rebinding) sends its own name, and is
//! refused. A server bound to every interface (`0.0.0.0`, `::`) also takes
//! any IP address, which no other site can borrow, but no other name.
//!
//! A request that carries an `Origin` must come from such an address over
//! `http`: a page of another site (or a sandboxed one, `Origin: null`)
//! can neither open a WebSocket nor post anything. A state-changing request
//! without `Origin` is refused when `Sec-Fetch-Site` says the browser sent
//! it for another site. Clients that are not browsers send neither header
//! and are taken on their `Host` alone: they could reach the port anyway.
//!
//! The rule is applied by tower-http's `ValidateRequestHeaderLayer`;
//! parsing the addresses is `http`'s.

use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use axum::body::Body;
use axum::http::uri::Authority;
use axum::http::{header, Method, Request, Response, StatusCode, Uri};
use axum::response::IntoResponse;
use axum::Json;
use serde_json::json;
use tower_http::validate_request::ValidateRequest;

/// The addresses a server listening on one socket answers to.
#[derive(Clone, Debug)]
pub struct Guard {
    address: SocketAddr,
    /// Requests refused so far (shared by the clones).
    refused: Arc<AtomicU64>,
}

impl Guard {
    /// The guard of a server listening on `address` (with its real port).
    pub fn new(address: SocketAddr, refused: Arc<AtomicU64>) -> Guard {
        Guard { address, refused }
    }

    /// Whether `authority` (a `Host` header, or an origin's host and port)
    /// names this server.
    pub fn names_this_server(&self, authority: &str) -> bool {
        // A Host has no user part; an origin's authority neither.
        let Ok(authority) = authority.parse::<Authority>() else {
            return false;
        };
        if authority.as_str().contains('@') {
            return false;
        }
        // Both a Host and an origin leave out HTTP's default port.
        if authority.port_u16().unwrap_or(80) != self.address.port() {
            return false;
        }
        let host = authority.host();
        if host.eq_ignore_ascii_case("localhost") {
            return true;
        }
        let literal = host.trim_start_matches('[').trim_end_matches(']');
        let Ok(ip) = literal.parse::<IpAddr>() else {
            return false;
        };
        let bound = self.address.ip();
        ip == bound
            || ip == IpAddr::from([127, 0, 0, 1])
            || ip == IpAddr::from([0u16, 0, 0, 0, 0, 0, 0, 1])
            || bound.is_unspecified()
    }

    /// Why `request` may not reach the server, if it may not.
    pub fn check<B>(&self, request: &Request<B>) -> Result<(), String> {
        let headers = request.headers();
        let host = headers
            .get(header::HOST)
            .and_then(|h| h.to_str().ok())
            .ok_or("refused: the request names no Host")?;
        if !self.names_this_server(host) {
            return Err(format!(
                "refused: Host {host} is not this server's address ({})",
                self.addresses()
            ));
        }
        if let Some(origin) = headers.get(header::ORIGIN) {
            let origin = origin.to_str().unwrap_or("(not text)");
            if !self.is_own_origin(origin) {
                return Err(format!(
                    "refused: a page from {origin} may not use this preview"
                ));
            }
        } else if !matches!(
            *request.method(),
            Method::GET | Method::HEAD | Method::OPTIONS
        ) {
            let site = headers.get("sec-fetch-site").and_then(|s| s.to_str().ok());
            if site.is_some_and(|s| s != "same-origin" && s != "none") {
                return Err("refused: a page of another site may not use this preview".into());
            }
        }
        Ok(())
    }

    fn is_own_origin(&self, origin: &str) -> bool {
        let Ok(uri) = origin.parse::<Uri>() else {
            return false;
        };
        uri.scheme_str() == Some("http")
            && uri.path_and_query().is_none_or(|p| p.as_str() == "/")
            && uri
                .authority()
                .is_some_and(|a| self.names_this_server(a.as_str()))
    }

    /// The addresses accepted, for the refusal's message.
    fn addresses(&self) -> String {
        let port = self.address.port();
        let bound = self.address.ip();
        let mut names = vec![format!("127.0.0.1:{port}"), format!("localhost:{port}")];
        names.push(format!("[::1]:{port}"));
        if bound.is_unspecified() {
            names.push(format!("any IP address with port {port}"));
        } else if !bound.is_loopback() {
            names.push(SocketAddr::new(bound, port).to_string());
        }
        names.join(", ")
    }
}

impl<B> ValidateRequest<B> for Guard {
    type ResponseBody = Body;

    fn validate(&mut self, request: &mut Request<B>) -> Result<(), Response<Body>> {
        self.check(request).map_err(|message| {
            self.refused.fetch_add(1, Ordering::Relaxed);
            (StatusCode::FORBIDDEN, Json(json!({ "error": message }))).into_response()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guard(address: &str) -> Guard {
        Guard::new(address.parse().unwrap(), Arc::default())
    }

    #[test]
    fn hosts_are_the_listening_addresses_with_their_port() {
        let g = guard("127.0.0.1:8123");
        for host in [
            "127.0.0.1:8123",
            "localhost:8123",
            "LOCALHOST:8123",
            "[::1]:8123",
        ] {
            assert!(g.names_this_server(host), "{host}");
        }
        for host in [
            "evil.example:8123",
            "127.0.0.1:8124",
            "127.0.0.1",
            "localhost",
            "127.0.0.2:8123",
            "localhost.evil.example:8123",
            "192.168.1.5:8123",
            "",
            "user@127.0.0.1:8123",
        ] {
            assert!(!g.names_this_server(host), "{host}");
        }
        // --bind: its address too; every interface: any address, no name.
        let g = guard("192.168.1.5:80");
        assert!(g.names_this_server("192.168.1.5"));
        assert!(g.names_this_server("localhost:80"));
        assert!(!g.names_this_server("10.0.0.1:80"));
        let g = guard("0.0.0.0:8123");
        assert!(g.names_this_server("10.0.0.1:8123"));
        assert!(g.names_this_server("[fe80::1]:8123"));
        assert!(!g.names_this_server("evil.example:8123"));
    }

    fn request(method: &str, headers: &[(&str, &str)]) -> Request<()> {
        let mut r = Request::builder().method(method).uri("/api/reload");
        for (name, value) in headers {
            r = r.header(*name, *value);
        }
        r.body(()).unwrap()
    }

    #[test]
    fn foreign_origins_and_sites_are_refused() {
        let g = guard("127.0.0.1:8123");
        let host = ("host", "127.0.0.1:8123");
        for headers in [
            vec![host],
            vec![host, ("origin", "http://127.0.0.1:8123")],
            vec![host, ("origin", "http://localhost:8123")],
            vec![host, ("sec-fetch-site", "same-origin")],
        ] {
            assert_eq!(g.check(&request("POST", &headers)), Ok(()), "{headers:?}");
        }
        for headers in [
            vec![],
            vec![("host", "evil.example:8123")],
            vec![host, ("origin", "http://evil.example")],
            vec![host, ("origin", "http://evil.example:8123")],
            vec![host, ("origin", "https://127.0.0.1:8123")],
            vec![host, ("origin", "http://127.0.0.1:9999")],
            vec![host, ("origin", "null")],
            vec![host, ("sec-fetch-site", "cross-site")],
            vec![host, ("sec-fetch-site", "same-site")],
        ] {
            assert!(g.check(&request("POST", &headers)).is_err(), "{headers:?}");
        }
        // A foreign origin is refused on a GET too (the WebSocket's upgrade).
        let upgrade = request("GET", &[host, ("origin", "http://evil.example")]);
        assert!(g.check(&upgrade).is_err());
        let navigation = request("GET", &[host, ("sec-fetch-site", "cross-site")]);
        assert_eq!(g.check(&navigation), Ok(()));
    }
}
