//! Targets over the binary wire formats and files: APT frames, Net F/T RDT datagrams, Modbus
//! RTU / TCP frames (the stage driver's responses, the emulated stage's requests), the run's
//! force log, pickles.

use fringe_rig::apt;
use fringe_rig::apt::{Flow, StreamDecoder};
use fringe_rig::modbus;
use fringe_rig::netft;
use fringe_rig::store;
use fringe_rig::{HostTime, RegisterMap};
use fringe_sim::ModbusCore;
use fringe_sim::{BenchConfig, SimMotor};
use std::sync::{Arc, OnceLock};

/// The APT stream decoder both ways, fed in chunks whose sizes come from the input itself (a
/// serial read returns any number of bytes), and the frame decoder on the whole input.
pub fn apt(data: &[u8]) {
    for flow in [Flow::FromDevice, Flow::ToDevice] {
        let mut decoder = StreamDecoder::new(flow);
        let mut rest = data;
        let mut chunk = 1usize;
        while !rest.is_empty() {
            let take = chunk.min(rest.len());
            decoder.push(&rest[..take]);
            while decoder.next_item().is_some() {}
            chunk = usize::from(rest[0] % 23) + 1;
            rest = &rest[take..];
        }
        assert!(
            decoder.pending() <= data.len(),
            "the decoder holds more than it was given"
        );
    }
    let _ = apt::frame_len(data);
    let _ = apt::decode(data);
}

/// RDT requests and response datagrams; every record of a decoded datagram is read.
pub fn rdt(data: &[u8]) {
    let _ = netft::Request::decode(data);
    if let Ok(records) = netft::decode_datagram(data) {
        for record in records {
            std::hint::black_box(record);
        }
    }
}

/// Modbus responses as the stage driver parses them (RTU and TCP), matched against the requests
/// it sends; requests as the emulator decodes them.
pub fn modbus(data: &[u8]) {
    let requests = [
        modbus::Request::ReadHolding {
            start: 0x0100,
            count: 4,
        },
        modbus::Request::WriteSingle {
            address: 0x0200,
            value: 1,
        },
        modbus::Request::WriteMultiple {
            start: 0x0300,
            values: vec![1, 2],
        },
    ];
    let responses = [
        modbus::parse_rtu(data).ok().and_then(frame_response),
        modbus::parse_tcp(data).ok().and_then(frame_response),
        modbus::decode_response_pdu(data).ok(),
    ];
    for response in responses.iter().flatten() {
        for request in &requests {
            let _ = modbus::match_reply(request, response);
        }
    }
    let _ = fringe_sim::decode_request_pdu(data);
    for map in builtin_maps() {
        let mut core = ModbusCore::new(
            map.clone(),
            Arc::new(SimMotor::new(BenchConfig::default().y.spec("y"))),
        );
        let _ = core.handle_pdu(data, HostTime(1_000_000_000));
    }
}

/// The built-in register maps, read once.
fn builtin_maps() -> &'static [RegisterMap] {
    static MAPS: OnceLock<Vec<RegisterMap>> = OnceLock::new();
    MAPS.get_or_init(|| {
        ["oriental-az", "leadshine-pr"]
            .into_iter()
            .map(|name| match RegisterMap::load(name) {
                Ok(map) => map,
                Err(e) => panic!("built-in register map {name} is refused: {e}"),
            })
            .collect()
    })
}

fn frame_response<H>(parsed: modbus::Parsed<H>) -> Option<modbus::Response> {
    match parsed {
        modbus::Parsed::Frame { response, .. } => Some(response),
        _ => None,
    }
}

/// The FGL frame codec, on a stored frame file's bytes.
pub fn fgl(data: &[u8]) {
    let _ = fringe_rig::store::fgl_header(data);
    let _ = fringe_rig::store::decode_fgl(data);
}

/// A run's force log (`force.bin`), header and records.
pub fn force_log(data: &[u8]) {
    let _ = store::check_force_log_header(data);
    let _ = store::decode_force_log(data);
}

/// The pickle reader that `torch.save` files go through.
pub fn pickle(data: &[u8]) {
    let _ = fringe_sensor_models::parse_pickle(data);
    let _ = fringe_sensor_models::parse_pickle_prefix(data);
}
