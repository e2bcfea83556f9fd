//! Clock tree of the STM32F407G-DISC1: the 8 MHz crystal (HSE) feeds the main PLL.
//!
//! | clock            | source                       | frequency |
//! |------------------|------------------------------|-----------|
//! | PLL input        | HSE 8 MHz / M 4              | 2 MHz     |
//! | VCO              | × N 168                      | 336 MHz   |
//! | SYSCLK, HCLK     | VCO / P 2                    | 168 MHz   |
//! | 48 MHz (USB OTG) | VCO / Q 7                    | 48 MHz    |
//! | APB1 (USART2/3, UART4) | HCLK / 4               | 42 MHz    |
//! | APB2             | HCLK / 2                     | 84 MHz    |
//!
//! A 2 MHz PLL input is what RM0090 recommends (RCC_PLLCFGR, PLLM) to limit PLL jitter. At
//! 42 MHz the USART divider is exact for 500 kBd (84) and 9600 Bd (4375); 921 600 Bd comes out
//! at 913 043 Bd (−0.93 %).

use embassy_stm32::Config;
use embassy_stm32::rcc::{
    AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv, PllQDiv, PllSource,
    Sysclk, mux,
};
use embassy_stm32::time::Hertz;

/// The frequency of the crystal on the Discovery board (X2).
const HSE_HZ: u32 = 8_000_000;

/// Peripheral configuration with the clock tree above.
pub fn config() -> Config {
    let mut config = Config::default();
    let rcc = &mut config.rcc;
    rcc.hse = Some(Hse {
        freq: Hertz(HSE_HZ),
        mode: HseMode::Oscillator,
    });
    rcc.pll_src = PllSource::HSE;
    rcc.pll = Some(Pll {
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL168,
        divp: Some(PllPDiv::DIV2),
        divq: Some(PllQDiv::DIV7),
        divr: None,
    });
    rcc.sys = Sysclk::PLL1_P;
    rcc.ahb_pre = AHBPrescaler::DIV1;
    rcc.apb1_pre = APBPrescaler::DIV4;
    rcc.apb2_pre = APBPrescaler::DIV2;
    rcc.mux.clk48sel = mux::Clk48sel::PLL1_Q;
    config
}
