//! The recording reader on arbitrary `frames.jsonl` bytes (a `.jsonl` object list from a stream). Cloud paths
//! must stay relative and inside the recording, so whatever the input names, nothing outside is read.
#![no_main]
use libfuzzer_sys::fuzz_target;
use pmon_recording::RecordingReader;

fuzz_target!(|data: &[u8]| {
    let Ok(reader) =
        RecordingReader::from_reader(Box::new(std::io::Cursor::new(data.to_vec())), std::path::Path::new("fuzz.jsonl"))
    else {
        return;
    };
    for frame in reader.take(1000) {
        if frame.is_err() {
            break;
        }
    }
});
