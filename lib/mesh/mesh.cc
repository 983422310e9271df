// placeholder: implemented in issue 2
