//! UDP datagrams from pcap captures (Ethernet, 802.1Q VLAN, Linux cooked
//! capture, raw IPv4).

use std::net::{Ipv4Addr, SocketAddrV4};
use std::path::Path;

use pcap_file::pcap::PcapReader;
use pcap_file::DataLink;

/// One UDP datagram of a capture.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Datagram {
    /// Capture time, nanoseconds since the Unix epoch.
    pub time_ns: u64,
    pub src: SocketAddrV4,
    pub dst: SocketAddrV4,
    pub payload: Vec<u8>,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PcapCounters {
    pub frames: u64,
    pub udp: u64,
    /// Not IPv4/UDP (ARP, TCP, IPv6, ...).
    pub other: u64,
    /// Cut by the capture's snap length or malformed headers.
    pub truncated: u64,
    /// Fragmented IPv4 (not reassembled).
    pub fragments: u64,
}

#[derive(Debug, thiserror::Error)]
pub enum PcapError {
    #[error("cannot open {path}: {source}")]
    Open {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {why}")]
    Format { path: String, why: String },
}

/// The IPv4 packet inside a link-layer frame.
fn ipv4_of(link: DataLink, f: &[u8]) -> Option<&[u8]> {
    match link {
        DataLink::ETHERNET => {
            let mut ethertype = u16::from_be_bytes([*f.get(12)?, *f.get(13)?]);
            let mut at = 14;
            while ethertype == 0x8100 || ethertype == 0x88A8 {
                ethertype = u16::from_be_bytes([*f.get(at + 2)?, *f.get(at + 3)?]);
                at += 4;
            }
            (ethertype == 0x0800).then(|| f.get(at..)).flatten()
        }
        DataLink::LINUX_SLL => {
            let proto = u16::from_be_bytes([*f.get(14)?, *f.get(15)?]);
            (proto == 0x0800).then(|| f.get(16..)).flatten()
        }
        DataLink::RAW | DataLink::IPV4 => Some(f),
        _ => None,
    }
}

enum Parsed<'a> {
    Udp(SocketAddrV4, SocketAddrV4, &'a [u8]),
    Other,
    Truncated,
    Fragment,
}

fn parse_udp(ip: &[u8]) -> Parsed<'_> {
    if ip.len() < 20 {
        return Parsed::Truncated;
    }
    if ip[0] >> 4 != 4 {
        return Parsed::Other;
    }
    let ihl = (ip[0] & 0x0F) as usize * 4;
    let total = u16::from_be_bytes([ip[2], ip[3]]) as usize;
    if ip[9] != 17 {
        return Parsed::Other;
    }
    let flags_frag = u16::from_be_bytes([ip[6], ip[7]]);
    if flags_frag & 0x3FFF != 0 {
        return Parsed::Fragment;
    }
    if ihl < 20 || total < ihl + 8 || ip.len() < total {
        return Parsed::Truncated;
    }
    let src_ip = Ipv4Addr::new(ip[12], ip[13], ip[14], ip[15]);
    let dst_ip = Ipv4Addr::new(ip[16], ip[17], ip[18], ip[19]);
    let udp = &ip[ihl..total];
    let sport = u16::from_be_bytes([udp[0], udp[1]]);
    let dport = u16::from_be_bytes([udp[2], udp[3]]);
    let ulen = u16::from_be_bytes([udp[4], udp[5]]) as usize;
    if ulen < 8 || ulen > udp.len() {
        return Parsed::Truncated;
    }
    Parsed::Udp(
        SocketAddrV4::new(src_ip, sport),
        SocketAddrV4::new(dst_ip, dport),
        &udp[8..ulen],
    )
}

/// A pcap file's global header: magic, version, zone, accuracy, snap
/// length, link type.
const PCAP_HEADER_BYTES: u64 = 24;

/// Every UDP datagram of a capture, in capture order.
pub fn read_udp(path: &Path) -> Result<(Vec<Datagram>, PcapCounters), PcapError> {
    let p = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|source| PcapError::Open {
        path: p.clone(),
        source,
    })?;
    // A directory opens, and an empty file is a valid stream of nothing:
    // both are named here rather than as a reader's failure to read.
    let len = file
        .metadata()
        .map_err(|source| PcapError::Open {
            path: p.clone(),
            source,
        })
        .map(|m| if m.is_dir() { None } else { Some(m.len()) })?;
    match len {
        None => {
            return Err(PcapError::Format {
                path: p,
                why: "a directory, not a pcap capture".into(),
            })
        }
        Some(n) if n < PCAP_HEADER_BYTES => {
            return Err(PcapError::Format {
                path: p,
                why: format!(
                    "{n} bytes, shorter than a pcap file header ({PCAP_HEADER_BYTES} bytes)"
                ),
            })
        }
        Some(_) => {}
    }
    let mut reader = PcapReader::new(file).map_err(|e| PcapError::Format {
        path: p.clone(),
        why: format!("not a pcap capture: {e}"),
    })?;
    let link = reader.header().datalink;
    let mut out = Vec::new();
    let mut c = PcapCounters::default();
    while let Some(pkt) = reader.next_packet() {
        let pkt = match pkt {
            Ok(pkt) => pkt,
            Err(e) => {
                // A capture cut mid-record keeps what came before.
                tracing_free_warn(&p, &e.to_string());
                c.truncated += 1;
                break;
            }
        };
        c.frames += 1;
        if (pkt.data.len() as u32) < pkt.orig_len {
            c.truncated += 1;
            continue;
        }
        let Some(ip) = ipv4_of(link, &pkt.data) else {
            c.other += 1;
            continue;
        };
        match parse_udp(ip) {
            Parsed::Udp(src, dst, payload) => {
                c.udp += 1;
                out.push(Datagram {
                    time_ns: pkt.timestamp.as_nanos() as u64,
                    src,
                    dst,
                    payload: payload.to_vec(),
                });
            }
            Parsed::Other => c.other += 1,
            Parsed::Truncated => c.truncated += 1,
            Parsed::Fragment => c.fragments += 1,
        }
    }
    Ok((out, c))
}

fn tracing_free_warn(path: &str, why: &str) {
    eprintln!(
        "warning: {path}: the capture ends in a damaged record ({why}); kept what came before"
    );
}
