//! A network device's address, `HOST[:PORT]`: a name, an IPv4 address, a bare IPv6 address, or
//! `[v6]:PORT`. One reading for the command line (`--netft`, `--modbus-tcp`) and the rig file
//! (`force.address`, `y.address`).

use std::fmt;

/// A host and a port.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HostPort {
    /// A name or an IP address (an IPv6 address without brackets).
    pub host: String,
    pub port: u16,
}

/// Text that is not `HOST[:PORT]`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{text:?}: expected {expected} (for example {example}; an IPv6 address as [fe80::1]:{port_example})")]
pub struct HostPortError {
    pub text: String,
    expected: &'static str,
    example: String,
    port_example: u16,
}

impl HostPort {
    /// Reads `text`; `default_port` is the port of a bare host (`None`: the port is required).
    pub fn parse(text: &str, default_port: Option<u16>) -> Result<HostPort, HostPortError> {
        let bad = || HostPortError {
            text: text.to_string(),
            expected: if default_port.is_some() {
                "HOST or HOST:PORT"
            } else {
                "HOST:PORT"
            },
            example: format!("192.168.1.1:{}", default_port.unwrap_or(502)),
            port_example: default_port.unwrap_or(502),
        };
        let port = |p: &str| p.parse::<u16>().map_err(|_| bad());
        let text_trimmed = text.trim();
        let (host, port) = if let Some(rest) = text_trimmed.strip_prefix('[') {
            let (host, after) = rest.split_once(']').ok_or_else(bad)?;
            match after.strip_prefix(':') {
                Some(p) => (host, port(p)?),
                None if after.is_empty() => (host, default_port.ok_or_else(bad)?),
                None => return Err(bad()),
            }
        } else {
            match text_trimmed.split_once(':') {
                Some((host, p)) if !p.contains(':') => (host, port(p)?),
                // Two colons or more: a bare IPv6 address.
                Some(_) => (text_trimmed, default_port.ok_or_else(bad)?),
                None => (text_trimmed, default_port.ok_or_else(bad)?),
            }
        };
        if host.is_empty() || host.contains(['[', ']']) || host.contains(char::is_whitespace) {
            return Err(bad());
        }
        Ok(HostPort {
            host: host.to_string(),
            port,
        })
    }

    /// The host as it goes into a URL or before `:PORT` (an IPv6 address in brackets).
    pub fn url_host(&self) -> String {
        if self.host.contains(':') {
            format!("[{}]", self.host)
        } else {
            self.host.clone()
        }
    }
}

/// `host:port`, `[v6]:port`: what a socket address resolver reads.
impl fmt::Display for HostPort {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.url_host(), self.port)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hp(host: &str, port: u16) -> HostPort {
        HostPort {
            host: host.into(),
            port,
        }
    }

    #[test]
    fn names_v4_and_v6_with_and_without_a_port() {
        let d = Some(49152);
        assert_eq!(
            HostPort::parse("192.168.1.1", d),
            Ok(hp("192.168.1.1", 49152))
        );
        assert_eq!(
            HostPort::parse("ft.local:5000", d),
            Ok(hp("ft.local", 5000))
        );
        assert_eq!(HostPort::parse("[::1]:7", d), Ok(hp("::1", 7)));
        assert_eq!(HostPort::parse("[::1]", d), Ok(hp("::1", 49152)));
        assert_eq!(HostPort::parse("fe80::1", d), Ok(hp("fe80::1", 49152)));
        assert_eq!(hp("::1", 7).to_string(), "[::1]:7");
        assert_eq!(hp("ft.local", 7).to_string(), "ft.local:7");
        assert_eq!(hp("fe80::1", 1).url_host(), "[fe80::1]");
    }

    #[test]
    fn what_is_not_an_address_is_refused_saying_what_is() {
        for bad in ["host:port", ":80", "", "[::1", "[::1]x", "a b:1", "h:70000"] {
            assert!(HostPort::parse(bad, Some(1)).is_err(), "{bad}");
        }
        // Without a default port, the port is required.
        let e = HostPort::parse("stage.local", None).expect_err("no port");
        assert!(e.to_string().contains("expected HOST:PORT"), "{e}");
        assert!(HostPort::parse("fe80::1", None).is_err());
        assert_eq!(
            HostPort::parse("[fe80::1]:502", None),
            Ok(hp("fe80::1", 502))
        );
        let e = HostPort::parse("host:port", Some(49152)).expect_err("bad port");
        assert_eq!(
            e.to_string(),
            "\"host:port\": expected HOST or HOST:PORT (for example 192.168.1.1:49152; an IPv6 address as [fe80::1]:49152)"
        );
    }
}
