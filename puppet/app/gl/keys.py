"""pyglet input to Dear ImGui input: keys, modifiers, text, mouse buttons and wheel."""
from __future__ import annotations

from imgui_bundle import imgui
from pyglet.window import key, mouse


def _key_map() -> dict[int, int]:
    K = imgui.Key
    m = {key.TAB: K.tab, key.BACKSPACE: K.backspace, key.RETURN: K.enter, key.ENTER: K.enter,
         key.ESCAPE: K.escape, key.INSERT: K.insert, key.DELETE: K.delete, key.SPACE: K.space,
         key.LEFT: K.left_arrow, key.RIGHT: K.right_arrow, key.UP: K.up_arrow, key.DOWN: K.down_arrow,
         key.PAGEUP: K.page_up, key.PAGEDOWN: K.page_down, key.HOME: K.home, key.END: K.end,
         key.LCTRL: K.left_ctrl, key.RCTRL: K.right_ctrl, key.LSHIFT: K.left_shift,
         key.RSHIFT: K.right_shift, key.LALT: K.left_alt, key.RALT: K.right_alt,
         key.LCOMMAND: K.left_super, key.RCOMMAND: K.right_super,
         key.MINUS: K.minus, key.EQUAL: K.equal, key.BRACKETLEFT: K.left_bracket,
         key.BRACKETRIGHT: K.right_bracket, key.BACKSLASH: K.backslash, key.SEMICOLON: K.semicolon,
         key.APOSTROPHE: K.apostrophe, key.COMMA: K.comma, key.PERIOD: K.period, key.SLASH: K.slash,
         key.GRAVE: K.grave_accent, key.NUM_ENTER: K.keypad_enter, key.NUM_ADD: K.keypad_add,
         key.NUM_SUBTRACT: K.keypad_subtract}
    for i in range(10):
        m[getattr(key, f"_{i}")] = getattr(K, f"_{i}")
    for c in "ABCDEFGHIJKLMNOPQRSTUVWXYZ":
        m[getattr(key, c)] = getattr(K, c.lower())
    for i in range(1, 13):
        m[getattr(key, f"F{i}")] = getattr(K, f"f{i}")
    return m


KEYS = _key_map()
BUTTONS = {mouse.LEFT: 0, mouse.RIGHT: 1, mouse.MIDDLE: 2}


class ImGuiInput:
    """Forwards a pyglet window's input events to ImGui's io (y flipped to top-down)."""

    def __init__(self, window):
        self.window = window
        self.io = imgui.get_io()
        self.chars = ""  # characters typed since the window last cleared it (shortcuts like "?")

    def _y(self, y: float) -> float:
        return self.window.height - y

    def _mods(self, modifiers: int) -> None:
        io = self.io
        io.add_key_event(imgui.Key.mod_ctrl, bool(modifiers & (key.MOD_CTRL | key.MOD_COMMAND)))
        io.add_key_event(imgui.Key.mod_shift, bool(modifiers & key.MOD_SHIFT))
        io.add_key_event(imgui.Key.mod_alt, bool(modifiers & key.MOD_ALT))

    def on_key_press(self, symbol, modifiers):
        self._mods(modifiers)
        if symbol in KEYS:
            self.io.add_key_event(KEYS[symbol], True)
        return True  # never let pyglet's default ESC close the window

    def on_key_release(self, symbol, modifiers):
        self._mods(modifiers)
        if symbol in KEYS:
            self.io.add_key_event(KEYS[symbol], False)
        return True

    def on_text(self, text):
        self.chars += text
        for ch in text:
            if ch.isprintable():
                self.io.add_input_character(ord(ch))

    def on_mouse_motion(self, x, y, dx, dy):
        self.io.add_mouse_pos_event(float(x), float(self._y(y)))

    def on_mouse_press(self, x, y, button, modifiers):
        self._mods(modifiers)
        self.io.add_mouse_pos_event(float(x), float(self._y(y)))
        if button in BUTTONS:
            self.io.add_mouse_button_event(BUTTONS[button], True)

    def on_mouse_release(self, x, y, button, modifiers):
        self._mods(modifiers)
        self.io.add_mouse_pos_event(float(x), float(self._y(y)))
        if button in BUTTONS:
            self.io.add_mouse_button_event(BUTTONS[button], False)

    def on_mouse_drag(self, x, y, dx, dy, buttons, modifiers):
        self._mods(modifiers)
        self.io.add_mouse_pos_event(float(x), float(self._y(y)))

    def on_mouse_scroll(self, x, y, scroll_x, scroll_y):
        self.io.add_mouse_pos_event(float(x), float(self._y(y)))
        self.io.add_mouse_wheel_event(float(scroll_x), float(scroll_y))

    def on_mouse_leave(self, x, y):
        self.io.add_mouse_pos_event(-3.4e38, -3.4e38)

    def on_deactivate(self):
        self.io.add_focus_event(False)

    def on_activate(self):
        self.io.add_focus_event(True)
