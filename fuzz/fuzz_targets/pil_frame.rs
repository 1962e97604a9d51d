//! The PIL frame reader and decoder on arbitrary bytes: never a panic; every frame that
//! decodes re-encodes to a frame that decodes to the same bytes again.
#![no_main]

use beam_wire::{decode, encode, DriveMessage, FrameReader, HostMessage, MAX_FRAME};
use libfuzzer_sys::fuzz_target;

fn roundtrip<T>(frame: &[u8])
where
    T: serde::Serialize + for<'de> serde::Deserialize<'de> + beam_wire::Message,
{
    let mut copy = frame.to_vec();
    if let Ok(msg) = decode::<T>(&mut copy) {
        let mut buf = [0u8; MAX_FRAME + 1];
        let once = encode(&msg, &mut buf)
            .expect("a decoded message re-encodes")
            .to_vec();
        let mut body = once[..once.len() - 1].to_vec();
        let again: T = decode(&mut body).expect("a re-encoded message decodes");
        let mut buf2 = [0u8; MAX_FRAME + 1];
        let twice = encode(&again, &mut buf2).expect("re-encodes").to_vec();
        assert_eq!(once, twice);
    }
}

fuzz_target!(|data: &[u8]| {
    let mut reader = FrameReader::new();
    for &b in data {
        if let Some(Ok(frame)) = reader.push(b) {
            let frame = frame.to_vec();
            roundtrip::<HostMessage>(&frame);
            roundtrip::<DriveMessage>(&frame);
        }
    }
});
