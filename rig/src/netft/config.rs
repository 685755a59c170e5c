//! Scaling of RDT counts: counts per force / torque and units, from configuration or from the
//! sensor's own `netftapi2.xml` (fetched over plain HTTP).

use super::rdt::Record;
use crate::force::ForceError;
use crate::ft_units::{newton_metres_per, newtons_per, FORCE_UNITS, TORQUE_UNITS};
use crate::units::{Hertz, Wrench};
use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

/// How a Net F/T turns counts into N and N m.
#[derive(Debug, Clone, PartialEq)]
pub struct NetFtConfig {
    /// Counts per force unit (`cfgcpf`).
    pub counts_per_force: f64,
    /// Counts per torque unit (`cfgcpt`).
    pub counts_per_torque: f64,
    /// The force unit the counts refer to (`scfgfu`), as the sensor spells it.
    pub force_unit: String,
    /// The torque unit the counts refer to (`scfgtu`), as the sensor spells it.
    pub torque_unit: String,
    /// RDT output rate configured on the sensor (`comrdtrate`), if known.
    pub rdt_rate: Option<Hertz>,
    newtons_per_count: f64,
    newton_metres_per_count: f64,
}

impl NetFtConfig {
    /// Scaling from counts per force/torque in the given units; `origin` names where the numbers
    /// came from (for errors).
    pub fn new(
        counts_per_force: f64,
        counts_per_torque: f64,
        force_unit: &str,
        torque_unit: &str,
        origin: &str,
    ) -> Result<NetFtConfig, ForceError> {
        let err = |message: String| ForceError::Config {
            origin: origin.to_string(),
            message,
        };
        for (name, v) in [
            ("counts per force", counts_per_force),
            ("counts per torque", counts_per_torque),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(err(format!("{name} is {v}; it must be a positive number")));
            }
        }
        let fu = newtons_per(force_unit).ok_or_else(|| {
            err(format!(
                "force unit `{force_unit}` is unknown (known: {FORCE_UNITS})"
            ))
        })?;
        let tu = newton_metres_per(torque_unit).ok_or_else(|| {
            err(format!(
                "torque unit `{torque_unit}` is unknown (known: {TORQUE_UNITS})"
            ))
        })?;
        Ok(NetFtConfig {
            counts_per_force,
            counts_per_torque,
            force_unit: force_unit.to_string(),
            torque_unit: torque_unit.to_string(),
            rdt_rate: None,
            newtons_per_count: fu / counts_per_force,
            newton_metres_per_count: tu / counts_per_torque,
        })
    }

    /// Parses the sensor's `netftapi2.xml` (fields `cfgcpf`, `cfgcpt`, `scfgfu`, `scfgtu`,
    /// `comrdtrate`); `origin` (the URL or file) names it in errors.
    pub fn from_netftapi2(xml: &str, origin: &str) -> Result<NetFtConfig, ForceError> {
        let err = |message: String| ForceError::Config {
            origin: origin.to_string(),
            message,
        };
        let doc =
            roxmltree::Document::parse(xml).map_err(|e| err(format!("not valid XML: {e}")))?;
        let field = |tag: &str| -> Option<String> {
            doc.descendants()
                .find(|n| n.is_element() && n.tag_name().name() == tag)
                .map(|n| n.text().unwrap_or("").trim().to_string())
        };
        let required = |tag: &str, what: &str| -> Result<String, ForceError> {
            field(tag).ok_or_else(|| err(format!("element <{tag}> ({what}) is missing")))
        };
        let number = |tag: &str, what: &str| -> Result<f64, ForceError> {
            let text = required(tag, what)?;
            text.parse::<f64>()
                .map_err(|_| err(format!("<{tag}> ({what}) is `{text}`, not a number")))
        };
        let cpf = number("cfgcpf", "counts per force")?;
        let cpt = number("cfgcpt", "counts per torque")?;
        let fu = required("scfgfu", "force unit")?;
        let tu = required("scfgtu", "torque unit")?;
        let mut config = NetFtConfig::new(cpf, cpt, &fu, &tu, origin)?;
        if let Some(rate) = field("comrdtrate") {
            let hz = rate.parse::<f64>().map_err(|_| {
                err(format!(
                    "<comrdtrate> (RDT output rate) is `{rate}`, not a number"
                ))
            })?;
            config.rdt_rate = Some(Hertz(hz));
        }
        Ok(config)
    }

    /// Converts a record's counts to a wrench in N and N m.
    pub fn scale(&self, record: &Record) -> Wrench {
        let c = record.counts;
        let f = self.newtons_per_count;
        let t = self.newton_metres_per_count;
        Wrench::from_array([
            c[0] as f64 * f,
            c[1] as f64 * f,
            c[2] as f64 * f,
            c[3] as f64 * t,
            c[4] as f64 * t,
            c[5] as f64 * t,
        ])
    }
}

/// The URL of a sensor's configuration page: `http://HOST/netftapi2.xml`.
pub fn netftapi2_url(host: &str) -> String {
    format!("http://{host}/netftapi2.xml")
}

/// Fetches and parses `url` (`http://HOST[:PORT]/PATH`).
pub fn fetch_config(url: &str, timeout: Duration) -> Result<NetFtConfig, ForceError> {
    let body = http_get(url, timeout)?;
    NetFtConfig::from_netftapi2(&body, url)
}

/// The configuration of the box at `host` (as a URL writes it, `[v6]` bracketed) whose RDT port
/// is `rdt_port`: its page on HTTP port 80 ([`netftapi2_url`]), where a Net F/T serves it. Where
/// nothing listens on port 80 of that host (the connection refused at once, as on a computer
/// that runs an emulated box, which serves the page over TCP on its RDT port number: `fringe sim
/// serve`), the same page on TCP port `rdt_port`; if that fails too, the error of port 80.
pub fn fetch_box_config(
    host: &str,
    rdt_port: u16,
    timeout: Duration,
) -> Result<NetFtConfig, ForceError> {
    let url = netftapi2_url(host);
    match get(&url, timeout) {
        Ok(body) => NetFtConfig::from_netftapi2(&body, &url),
        Err((e, Some(std::io::ErrorKind::ConnectionRefused))) if rdt_port != 80 => {
            let beside = format!("http://{host}:{rdt_port}/netftapi2.xml");
            fetch_config(&beside, timeout).map_err(|_| e)
        }
        Err((e, _)) => Err(e),
    }
}

/// A URL or HTTP reply this minimal client cannot use.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum HttpError {
    #[error("`{0}` is not an http:// URL")]
    NotHttp(String),
    #[error("`{0}` has no host")]
    NoHost(String),
    #[error("`{0}`: unclosed `[`")]
    UnclosedBracket(String),
    #[error("`{url}`: `{port}` is not a port number")]
    BadPort { url: String, port: String },
    #[error("the reply ({0} bytes) is not an HTTP response")]
    NotAResponse(usize),
    #[error("the reply starts with `{0}`, not an HTTP status line")]
    NoStatusLine(String),
    #[error("the server answered `{0}`")]
    Status(String),
    #[error("truncated chunked body")]
    TruncatedChunk,
    #[error("bad chunk size `{0}`")]
    BadChunkSize(String),
    #[error("the body is not UTF-8 text")]
    NotUtf8,
}

/// A plain `http://` URL split into its parts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct HttpUrl {
    pub host: String,
    pub port: u16,
    pub path: String,
}

impl HttpUrl {
    /// Parses `http://HOST[:PORT][/PATH]`.
    pub(crate) fn parse(url: &str) -> Result<HttpUrl, HttpError> {
        let rest = url
            .strip_prefix("http://")
            .ok_or_else(|| HttpError::NotHttp(url.to_string()))?;
        let (authority, path) = match rest.find('/') {
            Some(i) => (&rest[..i], &rest[i..]),
            None => (rest, "/"),
        };
        if authority.is_empty() {
            return Err(HttpError::NoHost(url.to_string()));
        }
        // `[v6]:port`, `host:port` or a bare host.
        let (host, port) = if let Some(v6) = authority.strip_prefix('[') {
            let (h, after) = v6
                .split_once(']')
                .ok_or_else(|| HttpError::UnclosedBracket(url.to_string()))?;
            match after.strip_prefix(':') {
                Some(p) => (h.to_string(), parse_port(p, url)?),
                None => (h.to_string(), 80),
            }
        } else {
            match authority.rsplit_once(':') {
                Some((h, p)) => (h.to_string(), parse_port(p, url)?),
                None => (authority.to_string(), 80),
            }
        };
        Ok(HttpUrl {
            host,
            port,
            path: path.to_string(),
        })
    }
}

fn parse_port(p: &str, url: &str) -> Result<u16, HttpError> {
    p.parse().map_err(|_| HttpError::BadPort {
        url: url.to_string(),
        port: p.to_string(),
    })
}

/// GETs `url` over HTTP/1.0 with `std::net::TcpStream` and returns the body of a 200 reply.
pub(crate) fn http_get(url: &str, timeout: Duration) -> Result<String, ForceError> {
    get(url, timeout).map_err(|(e, _)| e)
}

/// [`http_get`], with how the connection failed when it could not be made.
fn get(url: &str, timeout: Duration) -> Result<String, (ForceError, Option<std::io::ErrorKind>)> {
    let plain = |e: ForceError| (e, None);
    let err = |message: String| ForceError::Config {
        origin: url.to_string(),
        message,
    };
    let parsed = HttpUrl::parse(url).map_err(|e| plain(err(e.to_string())))?;
    let addr = (parsed.host.as_str(), parsed.port)
        .to_socket_addrs()
        .map_err(|e| {
            plain(err(format!(
                "cannot resolve {}: {e} (check the sensor's host name or give its IP address)",
                parsed.host
            )))
        })?
        .next()
        .ok_or_else(|| plain(err(format!("{} resolves to no address", parsed.host))))?;
    let hint = "check the sensor is powered and reachable (ping it, open the URL in a browser), or pass --cpf and --cpt";
    let mut stream = TcpStream::connect_timeout(&addr, timeout).map_err(|e| {
        (
            err(format!("cannot connect to {addr}: {e} ({hint})")),
            Some(e.kind()),
        )
    })?;
    let io = |e: std::io::Error| {
        plain(err(format!(
            "HTTP exchange with {addr} failed: {e} ({hint})"
        )))
    };
    stream.set_read_timeout(Some(timeout)).map_err(io)?;
    stream.set_write_timeout(Some(timeout)).map_err(io)?;
    let request = format!(
        "GET {} HTTP/1.0\r\nHost: {}\r\nConnection: close\r\nAccept: */*\r\n\r\n",
        parsed.path, parsed.host
    );
    stream.write_all(request.as_bytes()).map_err(io)?;
    let mut reply = Vec::new();
    stream.read_to_end(&mut reply).map_err(io)?;
    parse_http_response(&reply).map_err(|e| plain(err(e.to_string())))
}

/// Extracts the body of an HTTP response (status 200 required; chunked transfer handled).
pub fn parse_http_response(reply: &[u8]) -> Result<String, HttpError> {
    let split = reply
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .ok_or(HttpError::NotAResponse(reply.len()))?;
    let head = String::from_utf8_lossy(&reply[..split]);
    let body = &reply[split + 4..];
    let mut lines = head.lines();
    let status_line = lines.next().unwrap_or("");
    let code = status_line.split_whitespace().nth(1).unwrap_or("");
    if !status_line.starts_with("HTTP/") {
        return Err(HttpError::NoStatusLine(status_line.to_string()));
    }
    if code != "200" {
        return Err(HttpError::Status(status_line.to_string()));
    }
    let chunked = lines.any(|l| {
        let l = l.to_ascii_lowercase();
        l.starts_with("transfer-encoding:") && l.contains("chunked")
    });
    let body = if chunked {
        dechunk(body)?
    } else {
        body.to_vec()
    };
    String::from_utf8(body).map_err(|_| HttpError::NotUtf8)
}

fn dechunk(mut data: &[u8]) -> Result<Vec<u8>, HttpError> {
    let mut out = Vec::new();
    loop {
        let eol = data
            .windows(2)
            .position(|w| w == b"\r\n")
            .ok_or(HttpError::TruncatedChunk)?;
        let size_text = String::from_utf8_lossy(&data[..eol]);
        let size_text = size_text.split(';').next().unwrap_or("").trim();
        let size = usize::from_str_radix(size_text, 16)
            .map_err(|_| HttpError::BadChunkSize(size_text.to_string()))?;
        data = &data[eol + 2..];
        if size == 0 {
            return Ok(out);
        }
        if data.len() < size {
            return Err(HttpError::TruncatedChunk);
        }
        out.extend_from_slice(&data[..size]);
        data = data.get(size + 2..).unwrap_or(&[]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const XML: &str = "<?xml version=\"1.0\"?>\n<netft>\n <setserial>FT00000</setserial>\n <cfgcpf>1000000</cfgcpf>\n <cfgcpt>1000000</cfgcpt>\n <scfgfu>N</scfgfu>\n <scfgtu>Nm</scfgtu>\n <comrdtrate>7000</comrdtrate>\n</netft>\n";

    #[test]
    fn parses_the_fields_of_netftapi2() {
        let c = NetFtConfig::from_netftapi2(XML, "http://ft/netftapi2.xml").expect("parse");
        assert_eq!(c.counts_per_force, 1e6);
        assert_eq!(c.counts_per_torque, 1e6);
        assert_eq!(c.rdt_rate, Some(Hertz(7000.0)));
        let r = Record {
            counts: [1_000_000, -2_500_000, 0, 500_000, 0, -1],
            ..Record::default()
        };
        let w = c.scale(&r);
        assert_eq!(w.to_array(), [1.0, -2.5, 0.0, 0.5, 0.0, -1e-6]);
    }

    #[test]
    fn imperial_units_are_converted() {
        let xml = XML.replace(">N<", ">lbf<").replace(">Nm<", ">lbf-in<");
        let c = NetFtConfig::from_netftapi2(&xml, "x").expect("parse");
        let w = c.scale(&Record {
            counts: [1_000_000, 0, 0, 1_000_000, 0, 0],
            ..Record::default()
        });
        assert!((w.fx.0 - 4.448_221_615).abs() < 1e-6);
        assert!((w.tx.0 - 0.112_984_829).abs() < 1e-6);
    }

    #[test]
    fn missing_or_bad_fields_name_the_source_and_field() {
        let e = NetFtConfig::from_netftapi2(
            &XML.replace("cfgcpt", "other"),
            "http://10.0.0.5/netftapi2.xml",
        )
        .expect_err("missing");
        let t = e.to_string();
        assert!(
            t.contains("http://10.0.0.5/netftapi2.xml") && t.contains("<cfgcpt>"),
            "{t}"
        );
        let e =
            NetFtConfig::from_netftapi2(&XML.replace(">Nm<", ">parsec<"), "u").expect_err("unit");
        assert!(e.to_string().contains("torque unit `parsec`"), "{e}");
        let e = NetFtConfig::from_netftapi2(&XML.replace("1000000</cfgcpf", "abc</cfgcpf"), "u")
            .expect_err("nan");
        assert!(
            e.to_string()
                .contains("<cfgcpf> (counts per force) is `abc`"),
            "{e}"
        );
        assert!(NetFtConfig::from_netftapi2("<netft><cfg", "u").is_err());
        assert!(NetFtConfig::new(0.0, 1.0, "N", "Nm", "cli").is_err());
    }

    #[test]
    fn urls_and_responses() {
        assert_eq!(
            HttpUrl::parse("http://192.168.1.1/netftapi2.xml"),
            Ok(HttpUrl {
                host: "192.168.1.1".into(),
                port: 80,
                path: "/netftapi2.xml".into()
            })
        );
        assert_eq!(
            HttpUrl::parse("http://h:8080").map(|u| (u.port, u.path)),
            Ok((8080, "/".into()))
        );
        assert!(HttpUrl::parse("https://h/x").is_err());
        assert!(HttpUrl::parse("http://h:xx/").is_err());
        let ok = b"HTTP/1.1 200 OK\r\nContent-Type: text/xml\r\n\r\n<a/>";
        assert_eq!(parse_http_response(ok), Ok("<a/>".into()));
        let chunked = b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n3\r\n<a>\r\n4\r\n</a>\r\n0\r\n\r\n";
        assert_eq!(parse_http_response(chunked), Ok("<a></a>".into()));
        let missing = b"HTTP/1.1 404 Not Found\r\n\r\n";
        assert_eq!(
            parse_http_response(missing),
            Err(HttpError::Status("HTTP/1.1 404 Not Found".into()))
        );
        assert_eq!(
            parse_http_response(b"garbage"),
            Err(HttpError::NotAResponse(7))
        );
    }

    #[test]
    fn unreachable_url_error_names_it() {
        // Port 1 on loopback is closed: the connection is refused at once.
        let e = http_get(
            "http://127.0.0.1:1/netftapi2.xml",
            Duration::from_millis(500),
        )
        .expect_err("closed");
        let t = e.to_string();
        assert!(
            t.contains("http://127.0.0.1:1/netftapi2.xml") && t.contains("--cpf"),
            "{t}"
        );
    }
}
