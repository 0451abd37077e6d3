// Two looks: a light high-contrast theme for daylight at the pitch, a dark one for a dark hall; the choice is kept.
// Both meet WCAG AA contrast (tests/test_accessibility_browser.py runs axe-core on every preset in both).

import { KEYS, getText, setText } from "./settings.js";

const KEY = KEYS.theme;

export function currentTheme() {
  return document.documentElement.classList.contains("dark") ? "dark" : "light";
}

/** Applies the remembered theme and wires the button that switches it; onChange() after each switch. */
export function installTheme(button, onChange) {
  const root = document.documentElement;
  const apply = (theme) => {
    root.classList.toggle("dark", theme === "dark");
    button.textContent = theme === "dark" ? "light theme" : "dark theme";
    button.setAttribute("aria-pressed", String(theme === "dark"));
  };
  apply(getText(KEY) === "dark" ? "dark" : "light");
  button.addEventListener("click", () => {
    const theme = currentTheme() === "dark" ? "light" : "dark";
    apply(theme);
    setText(KEY, theme);
    onChange();
  });
}
