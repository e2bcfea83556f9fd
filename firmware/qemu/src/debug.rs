//! The debug channel: text lines on USART1, QEMU's first serial port, which `hil-sim --qemu`
//! reads beside the three data lines (defmt over RTT cannot be read from QEMU).
//!
//! Lines, one per event, `key value …`:
//!
//! * `boot stack_bytes=N stack_used_bytes=U laser_target_baud=B`: the USARTs listen and the
//!   tasks are spawned; the stack has N bytes, of which start-up used U; the laser will stream
//!   at B Bd.
//! * `baud NAME RATE`: the USART NAME (`laser`, `gps`, `host`) now runs at RATE Bd. QEMU
//!   ignores the divider; the simulator uses this to hear the line as a real UART would.
//! * `measure stack_used_bytes=… stack_bytes=… latency_max_cycles=… latency_samples=…
//!   core_hz=…`: the measurements ([`crate::stack`], [`crate::latency`]), every second.
//! * `panic MESSAGE at FILE:LINE`: the firmware panicked; QEMU then exits with status 1
//!   (semihosting).
//!
//! Writes poll the transmitter and hold a critical section for the whole line, so that lines
//! from tasks and interrupts never interleave. Under QEMU a byte leaves as it is written.

use core::fmt::{self, Write};

use stm32_metapac::USART1;
use stm32_metapac::usart::regs::Brr;

/// The debug line's rate (QEMU ignores it; a real board's USART1 would run at it).
const DEBUG_BAUD: u32 = 115_200;

/// Enables USART1's transmitter. Call before anything writes a line.
pub fn init(pclk_hz: u32) {
    USART1.brr().write_value(Brr(pclk_hz / DEBUG_BAUD));
    USART1.cr1().write(|w| {
        w.set_ue(true);
        w.set_te(true);
    });
}

struct Uart1;

impl Write for Uart1 {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for byte in s.bytes() {
            while !USART1.sr().read().txe() {}
            USART1.dr().write(|w| w.set_dr(u16::from(byte)));
        }
        Ok(())
    }
}

/// Writes one line.
pub fn line(args: fmt::Arguments<'_>) {
    critical_section::with(|_| {
        // Writing to the UART cannot fail.
        let _ = Uart1.write_fmt(args);
        let _ = Uart1.write_str("\n");
    });
}

/// Reports that the USART `name` runs at `baud`.
pub fn baud(name: &str, baud: u32) {
    line(format_args!("baud {name} {baud}"));
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    cortex_m::interrupt::disable();
    match info.location() {
        Some(at) => line(format_args!(
            "panic {} at {}:{}",
            info.message(),
            at.file(),
            at.line()
        )),
        None => line(format_args!("panic {}", info.message())),
    }
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
