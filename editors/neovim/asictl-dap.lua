-- asictl's debug adapter in nvim-dap (any Neovim nvim-dap runs on; put this in init.lua)
local ok, dap = pcall(require, "dap")
if ok then
  dap.adapters.asictl = { type = "executable", command = "asictl", args = { "dap" } }
  dap.configurations.asi = {
    { type = "asictl", request = "launch", name = "Debug this program", program = "${file}" },
    { type = "asictl", request = "launch", name = "Debug without its scenario",
      program = "${file}", noScenario = true, set = { "I 1.0=1" } },
    { type = "asictl", request = "attach", name = "Attach to the live board 300h",
      port = "300h", program = "${file}" },
  }
  -- step one program cycle: the adapter's own request
  vim.api.nvim_create_user_command("AsictlStepCycle", function()
    local session = dap.session()
    if session then
      session:request("stepCycle", { threadId = 1 }, function() end)
    end
  end, {})
end
