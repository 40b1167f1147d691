//! Serial ports as the host's link and a load cell's indicator both need them: which are
//! there (named in a "not found" error), and their input thrown away before a fresh read.

use std::io::{self, Read};
use std::time::Duration;

/// This machine's serial ports, one line each: the path, and for a USB port its vendor and
/// product ids, maker, product and serial (what tells one skin from another).
pub fn port_list() -> Vec<String> {
    let Ok(ports) = serialport::available_ports() else {
        return Vec::new();
    };
    ports
        .into_iter()
        .map(|p| match p.port_type {
            serialport::SerialPortType::UsbPort(u) => format!(
                "{}  USB {:04x}:{:04x} {} {} serial {}",
                p.port_name,
                u.vid,
                u.pid,
                u.manufacturer.unwrap_or_default(),
                u.product.unwrap_or_default(),
                u.serial_number.unwrap_or_else(|| "?".into())
            ),
            serialport::SerialPortType::PciPort => format!("{}  PCI", p.port_name),
            serialport::SerialPortType::BluetoothPort => format!("{}  Bluetooth", p.port_name),
            serialport::SerialPortType::Unknown => format!("{}  (not USB)", p.port_name),
        })
        .collect()
}

/// A port that is not there: the error names the ports that are.
pub fn with_ports_named(e: io::Error) -> io::Error {
    if e.kind() != io::ErrorKind::NotFound {
        return e;
    }
    let ports = port_list();
    let here = if ports.is_empty() {
        "no serial ports on this machine".to_string()
    } else {
        format!("serial ports here: {}", ports.join("; "))
    };
    io::Error::new(e.kind(), format!("{e} ({here})"))
}

/// Most bytes [`drain`] throws away: a backlog larger than this is a device streaming
/// faster than it can be drained, and what is left is the reader's to discard.
const DRAIN_MAX: u64 = 1 << 20;

/// Reads what waits in `port`'s input without waiting for more, throws it away, and says
/// how many bytes that was; then clears the input buffer for good measure and puts the
/// port's read timeout back. (The count comes from reading, because `FIONREAD` does not see
/// all of a pseudo-terminal's buffer.)
pub fn drain(port: &mut serialport::TTYPort) -> serialport::Result<u64> {
    use serialport::{ClearBuffer, SerialPort};
    let timeout = port.timeout();
    port.set_timeout(Duration::ZERO)?;
    let mut buf = [0u8; 4096];
    let mut total = 0u64;
    while total < DRAIN_MAX {
        match port.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => total += n as u64,
        }
    }
    port.clear(ClearBuffer::Input)?;
    port.set_timeout(timeout)?;
    Ok(total)
}
