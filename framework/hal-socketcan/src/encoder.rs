//! The absolute encoders on spidev: one device per chip select, read by a pipelined SPI word
//! (each answer arrives with the next command).

use jointctl_hal::condition::Conditioner;

pub(crate) struct Encoder {
    pub(crate) name: String,
    pub(crate) path: String,
    pub(crate) device: Option<spidev::Spidev>,
    pub(crate) offset_rad: f64,
    pub(crate) reversed: bool,
    pub(crate) conditioner: Conditioner,
}

pub(crate) fn spi_word(e: &mut Encoder, command: u16) -> Option<u16> {
    let dev = e.device.as_ref()?;
    let tx = command.to_be_bytes();
    let mut rx = [0u8; 2];
    let mut t = spidev::SpidevTransfer::read_write(&tx, &mut rx);
    dev.transfer(&mut t).ok()?;
    Some(u16::from_be_bytes(rx))
}
