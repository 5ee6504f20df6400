"""Draw the board's wiring diagram, firmware/wiring.png (matplotlib; run from anywhere).

The pins are those of ``firmware/src/board/hal_board.c``; the parts those of firmware/README.md.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyBboxPatch  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "wiring.png"


def box(ax, x, y, w, h, title, lines=(), color="#dfe9f5"):
    ax.add_patch(FancyBboxPatch((x, y), w, h, boxstyle="round,pad=0.02", fc=color, ec="#333",
                                lw=1.2))
    ax.text(x + w / 2, y + h - 0.25, title, ha="center", va="top", fontsize=9.5,
            fontweight="bold")
    for i, line in enumerate(lines):
        ax.text(x + 0.12, y + h - 0.65 - 0.32 * i, line, ha="left", va="top", fontsize=7.5,
                family="monospace")


def wire(ax, x0, y0, x1, y1, label, color="#444"):
    xm = (x0 + x1) / 2
    ax.plot([x0, xm, xm, x1], [y0, y0, y1, y1], color=color, lw=1.3)
    if x1 > x0:     # label above the segment leaving the part on the left
        ax.text(x0 + 0.08, y0 + 0.08, label, fontsize=7, color=color, ha="left")
    else:
        ax.text(x0 - 0.08, y0 + 0.08, label, fontsize=7, color=color, ha="right")


def main() -> None:
    fig, ax = plt.subplots(figsize=(13, 8.2))
    ax.set_xlim(0, 16)
    ax.set_ylim(0, 10.2)
    ax.axis("off")
    ax.set_title("thermocue display: STM32F405 board wiring (firmware/src/board/hal_board.c)",
                 fontsize=12)
    # the MCU board
    box(ax, 6.0, 1.2, 4.0, 7.6, "STM32F405 board", [
        "(Olimex STM32-H405", " or any STM32F405RG", " board, 8 MHz crystal)", "",
        "PA0  ADC1_IN0  contact", "PA1  ADC1_IN1  ambient", "PA2  ADC1_IN2  IR",
        "PA3  ADC1_IN3  heat sink", "PA4  ADC1_IN4  sample", "PA5-7,PB0 IN5-8 force 1-4",
        "PA8  TIM1_CH1  PWM 20 kHz", "PB1  direction", "PB2  relay", "PB10 fan",
        "PA9  USART1 TX", "PA10 USART1 RX", "3V3, GND"], color="#f3f3f3")
    # sensors, left
    box(ax, 0.3, 7.4, 4.2, 2.2, "Thermistors (x4)", [
        "10 kOhm NTC, B 3950 (contact:", "glued in the copper pad), to GND;",
        "10 kOhm 0.1 % from 3V3; 100 nF", "at each ADC pin"])
    wire(ax, 4.5, 8.5, 6.0, 7.6, "PA0,PA1,PA3,PA4")
    box(ax, 0.3, 5.3, 4.2, 1.7, "IR thermometer", [
        "MLX90614 (PWM out) + RC filter", "(10 kOhm, 10 uF): 0-3.3 V", "= 0-50 C, aimed at the finger"])
    wire(ax, 4.5, 6.1, 6.0, 6.95, "PA2")
    box(ax, 0.3, 2.4, 4.2, 2.5, "Force sensors (x4)", [
        "4 load cells (1 kg) under the", "pad's corners, each with an", "INA125P amplifier to",
        "0-3.3 V = 0-10 N (gain resistor", "per datasheet; zero at rest)"])
    wire(ax, 4.5, 3.6, 6.0, 6.3, "PA5-7, PB0")
    box(ax, 0.3, 0.3, 4.2, 1.7, "USB-serial adapter", [
        "3.3 V FTDI/CP2102 cable:", "RX <- PA9, TX -> PA10, GND", "host: /dev/ttyUSB0, 115200 8N1"])
    wire(ax, 4.5, 1.1, 6.0, 2.0, "PA9/PA10")
    # power side, right
    box(ax, 11.5, 6.6, 4.2, 2.9, "H-bridge", [
        "VNH5019 / BTS7960 module,", "12 V supply; PWM <- PA8,", "INA/INB <- PB1 (and its",
        "inverse), EN high;", "out -> relay -> Peltier"], color="#fbe9e0")
    wire(ax, 11.5, 8.0, 10.0, 5.6, "PA8 PWM, PB1 dir", color="#a33")
    box(ax, 11.5, 3.7, 4.2, 2.4, "Peltier relay", [
        "5 V relay module (opto),", "IN <- PB2: high = closed;", "normally open: a reset,",
        "a hung MCU (IWDG) or FAULT", "opens it"], color="#fbe9e0")
    wire(ax, 11.5, 4.9, 10.0, 4.9, "PB2", color="#a33")
    box(ax, 11.5, 1.3, 4.2, 2.0, "Peltier + pad + heat sink", [
        "TEC1-12706 (or 15 x 15 mm", "module), copper pad, finned", "heat sink; fan via MOSFET <- PB10"],
        color="#fbe9e0")
    wire(ax, 11.5, 2.3, 10.0, 2.6, "PB10 fan", color="#a33")
    ax.annotate("", xy=(13.6, 3.3), xytext=(13.6, 3.7),
                arrowprops=dict(arrowstyle="->", color="#a33", lw=1.5))
    ax.annotate("", xy=(13.6, 6.1), xytext=(13.6, 6.6),
                arrowprops=dict(arrowstyle="->", color="#a33", lw=1.5))
    ax.text(8.0, 0.45, "All grounds common; sensor wiring shielded; every output low at reset "
                       "(relay open, bridge off).", ha="center", fontsize=8, style="italic")
    fig.savefig(OUT, dpi=110, bbox_inches="tight")
    print(OUT)


if __name__ == "__main__":
    main()
